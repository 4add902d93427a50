"""Projection speed: shbake vs ducc0 vs the previous shbake (2b78de2), same run, same maps.

Random positive RGB float32 lat-long maps (512×256, 2048×1024, 4096×2048);
lmax 2, 8, 30. Every implementation integrates the same nodes with the same
Fejér weights (ducc0 gets them as ``ringfactor``, reads the interleaved
image with ``pixstride=3``, one call per channel, in float32, its fastest
mode); the coefficients agree to 1e-6 relative here (float32 in ducc0) and to
1e-12 with float64 input in ``tests/sh/test_projection_speed_paths.py``.

1 thread: ``SHBAKE_THREADS=1``, ducc0 ``nthreads=1``, the previous shbake with
``numba.set_num_threads(1)``; CPU time of the thread. 2 threads: wall time.
BLAS/OpenMP pools 1 thread. The read-once bound is measured in the same run:
``img.max()`` (numpy, one SIMD pass over the float32 image).

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/projection.py [N]
"""

import os
import sys
import time

import numpy as np
from timing import interleaved, machine, med, previous_module, ratio

from shbake.sh.projection import fejer_row_weights, project_latlong

try:
    import ducc0
except ImportError:  # pragma: no cover - test extra
    ducc0 = None


def ducc0_project(img, lmax, threads):
    h, w, nc = img.shape
    theta = np.pi * (np.arange(h) + 0.5) / h
    flat = img.reshape(1, -1)
    return [
        ducc0.sht.experimental.adjoint_synthesis(
            map=flat[:, c:],
            theta=theta,
            lmax=lmax,
            spin=0,
            nphi=np.full(h, w, dtype=np.uintp),
            phi0=np.full(h, np.pi / w),
            ringstart=(np.arange(h) * w * nc).astype(np.uintp),
            pixstride=nc,
            ringfactor=fejer_row_weights(h, w),
            nthreads=threads,
        )
        for c in range(nc)
    ]


def rows(n, threads, sizes, lmaxes):
    import numba

    numba.set_num_threads(threads)  # the previous shbake's prange kernels
    os.environ["SHBAKE_THREADS"] = str(threads)
    prev = previous_module("shbake/sh/projection.py", "projection_2b78de2")
    clock = time.thread_time if threads == 1 else time.perf_counter
    rng = np.random.default_rng(0)
    for h in sizes:
        img = rng.random((h, 2 * h, 3), dtype=np.float32)
        for lmax in lmaxes:
            fns = {
                "read": lambda img=img: img.max(),
                "shbake": lambda img=img, lmax=lmax: project_latlong(img, lmax, method="numba"),
                "ducc0": lambda img=img, lmax=lmax: ducc0_project(img, lmax, threads),
            }
            if prev is not None:
                fns["previous"] = lambda img=img, lmax=lmax: prev.project_latlong(img, lmax)
            t = interleaved(fns, n=n, clock=clock)
            a = project_latlong(img, lmax, method="numba")[0, 0]
            b = ducc0_project(img, lmax, 1)[0][0][0].real
            assert abs(a - b) < 1e-6 * abs(b), (a, b)
            prev_cols = (
                f"{med(t['previous'])} | {ratio(t['previous'], t['shbake'])}"
                if prev is not None
                else "– | –"
            )
            read = med(t["read"], fmt="{:.2f}")
            print(
                f"| {2 * h}×{h} | {lmax} | {threads} | {med(t['shbake'])} | {med(t['ducc0'])} | "
                f"{ratio(t['ducc0'], t['shbake'])} | {prev_cols} | {read} | "
                f"{ratio(t['shbake'], t['read'])} |"
            )


def main(n: int = 7):
    if ducc0 is None:
        sys.exit("ducc0 (a test extra) is needed for this benchmark")
    print(f"machine: {machine()}; median (min–max) of {n} interleaved runs, ms\n")
    print(
        "| map | lmax | threads | shbake ms | ducc0 ms | ducc0 / shbake | previous shbake ms | "
        "previous / shbake | read-once ms | shbake / read-once |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows(n, 1, (256, 1024, 2048), (2, 8, 30))
    rows(n, 2, (1024, 2048), (8,))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
