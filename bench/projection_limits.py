"""Where the lat-long projection's time goes at 4096×2048 RGB float32, 1 thread (issue 15).

The longitude stage (:func:`shbake.sh.projection.row_sums`: fold + dot products)
is timed twice per ``lmax``: on 16 rows that stay in the L2 cache, called 128
times (its compute alone), and on the whole 2048-row map streamed from memory.
``lmax 0`` is the fold alone (its one dot product is the row sum); the
difference between ``lmax 8`` and ``lmax 0`` in cache is the dot products.
Read-once: ``img.max()`` over the map (one SIMD pass, as bench/projection.py).
Median (min–max) of N runs, ms per 2048 rows.

    OMP_NUM_THREADS=1 .venv/bin/python bench/projection_limits.py [N]
"""

import os
import sys
import time

os.environ["SHBAKE_THREADS"] = "1"

import numpy as np  # noqa: E402
from timing import machine, med  # noqa: E402

from shbake.sh.projection import row_sums  # noqa: E402

W, H, IN_CACHE_ROWS = 4096, 2048, 16


def _time(fn, n):
    fn()
    ts = []
    for _ in range(n):
        t = time.thread_time()
        fn()
        ts.append(time.thread_time() - t)
    return ts


def main(n: int = 7):
    rng = np.random.default_rng(0)
    full = rng.random((H, W, 3), dtype=np.float32)
    small = np.ascontiguousarray(full[:IN_CACHE_ROWS])
    calls = H // IN_CACHE_ROWS
    print(f"machine: {machine()}; {W}×{H} RGB float32, 1 thread, median (min–max) of {n}, ms\n")
    print("| lmax | in cache (compute) | streamed from memory | memory − compute |")
    print("|---|---|---|---|")
    for lmax in (0, 2, 8, 30):
        cached = _time(lambda lmax=lmax: [row_sums(small, lmax) for _ in range(calls)], n)
        streamed = _time(lambda lmax=lmax: row_sums(full, lmax), n)
        gap = np.median(streamed) - np.median(cached)
        print(f"| {lmax} | {med(cached)} | {med(streamed)} | {1e3 * gap:.1f} |")
    print(f"\nread-once (`img.max()`): {med(_time(full.max, n))} ms")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
