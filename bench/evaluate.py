"""SH reconstruction speed: ``evaluate`` (fused, blocked) vs sphericart + matmul, same run.

1.57 M directions (a 512²×6 cube's texel count, random unit vectors), RGB
coefficients, lmax 2 / 8 / 30. Peers: sphericart 2.0.4 (``compute`` then
``@ coeffs``, float64, OpenMP pinned to 1 thread), the previous shbake
(2b78de2: stored basis then ``@``). Stored basis: ``real_sh_into`` into a
preallocated output vs sphericart ``compute`` vs the previous
``real_sh_numba``. 1 thread (``SHBAKE_THREADS=1``, ``numba.set_num_threads(1)``,
``OMP_NUM_THREADS=1``), CPU time of the calling thread; median (min–max) of N
interleaved runs. lmax 30's stored basis (12 GB) is skipped.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/evaluate.py [N]
"""

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from timing import interleaved, machine, med, previous_module, ratio  # noqa: E402

from shbake.sh.basis import evaluate, real_sh_into  # noqa: E402

try:
    import sphericart
except ImportError:  # pragma: no cover - test extra
    sphericart = None

N_DIRS = 512 * 512 * 6
CHUNK = 1 << 16
"""sphericart runs on chunks: its basis at lmax 30 for all directions would be 12 GB."""


def main(n: int = 5):
    import numba

    if sphericart is None:
        sys.exit("sphericart (a test extra) is needed for this benchmark")
    numba.set_num_threads(1)
    os.environ["SHBAKE_THREADS"] = "1"
    prev = previous_module("shbake/sh/basis.py", "basis_2b78de2")
    rng = np.random.default_rng(0)
    d = rng.normal(size=(N_DIRS, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    clock = time.thread_time
    print(f"machine: {machine()}; {N_DIRS} directions, 1 thread, median (min–max) of {n}, ms\n")
    print(
        "| lmax | evaluate ms | sphericart + matmul ms | ratio | previous shbake ms | "
        "ratio | evaluate on 0 directions (fixed overhead) ms |"
    )
    print("|---|---|---|---|---|---|---|")
    for lmax in (2, 8, 30):
        c = rng.normal(size=((lmax + 1) ** 2, 3))
        sc = sphericart.SphericalHarmonics(lmax)

        def peer(sc=sc, c=c):
            return np.concatenate(
                [sc.compute(d[s : s + CHUNK]) @ c for s in range(0, N_DIRS, CHUNK)]
            )

        fns = {
            "ours": lambda c=c: evaluate(c, d, method="numba"),
            "peer": peer,
            "checks": lambda c=c: evaluate(c, d[:0], method="numba"),
        }
        if prev is not None and lmax <= 8:
            fns["prev"] = lambda c=c: prev.evaluate(c, d)
        t = interleaved(fns, n=n, clock=clock)
        ref = peer()
        got = evaluate(c, d, method="numba")
        assert np.abs(got - ref).max() < 1e-11 * np.abs(ref).max()
        p = f"{med(t['prev'])} | {ratio(t['prev'], t['ours'])}" if "prev" in t else "– | –"
        print(
            f"| {lmax} | {med(t['ours'])} | {med(t['peer'])} | {ratio(t['peer'], t['ours'])} | "
            f"{p} | {med(t['checks'], fmt='{:.3f}')} |"
        )
    print("\nStored basis (N × (lmax+1)² float64):\n")
    print(
        "| lmax | real_sh_into, preallocated ms | sphericart compute ms | ratio | "
        "previous real_sh_numba ms | ratio |"
    )
    print("|---|---|---|---|---|---|")
    for lmax in (2, 8):
        sc = sphericart.SphericalHarmonics(lmax)
        out = np.empty((N_DIRS, (lmax + 1) ** 2))
        fns = {
            "ours": lambda lmax=lmax, out=out: real_sh_into(d, lmax, out),
            "peer": lambda sc=sc: sc.compute(d),
        }
        if prev is not None:
            fns["prev"] = lambda lmax=lmax: prev.real_sh_numba(d, lmax)
        t = interleaved(fns, n=n, clock=clock)
        p = f"{med(t['prev'])} | {ratio(t['prev'], t['ours'])}" if "prev" in t else "– | –"
        print(
            f"| {lmax} | {med(t['ours'])} | {med(t['peer'])} | {ratio(t['peer'], t['ours'])} | "
            f"{p} |"
        )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
