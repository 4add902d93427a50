"""Issue 31: process CPU of the per-map kernels of ``plan`` and ``bake`` on given maps.

    python bench/map_kernels.py MAP.exr [MAP.exr ...]

Per map, the best of 5 calls (``time.process_time``; run it with ``SHBAKE_THREADS=1
OPENBLAS_NUM_THREADS=1`` for one thread), averaged over the maps, in ms: the sun extraction,
the env_sh check's pyramid (built, then 256 Fibonacci directions queried), the SH-exp
targets of the default fit (``QuadraturePlan.e0``: pyramid, gather, point lights), one
weighted normal-matrix build (three a fit with two polish steps) and the fit to the
targets. Only public entry points are called, so an older tree runs it too (before/after
figures of docs/BENCHMARKS.md, "Fifth pass").
"""

import sys
import time

import numpy as np

REPEATS = 5


def best_ms(fn) -> float:
    """The least process CPU of :data:`REPEATS` calls of ``fn``, ms."""
    times = []
    for _ in range(REPEATS):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return 1e3 * min(times)


def measure(env, plan, queries) -> dict[str, float]:
    """CPU ms of each kernel on one map (module docstring); ``plan``: the fit plan of its
    shape."""
    from shbake.envmap.sun import extract_sun
    from shbake.reference.irradiance_pyramid import IrradiancePyramid

    pyramid = IrradiancePyramid(env)
    e0 = plan.targets.e0(env.pixels)
    weights = np.abs(np.random.default_rng(0).standard_normal(e0.shape)) + 0.5
    return {
        "extract_sun": best_ms(lambda: extract_sun(env)),
        "IrradiancePyramid(env)": best_ms(lambda: IrradiancePyramid(env)),
        f"pyramid, {queries.shape[0]} queries": best_ms(lambda: pyramid.irradiance(queries)),
        "QuadraturePlan.e0": best_ms(lambda: plan.targets.e0(env.pixels)),
        "Design.normal_matrices": best_ms(lambda: plan.design.normal_matrices(weights)),
        "FitPlan.fit_targets": best_ms(lambda: plan.fit_targets(e0)),
    }


def main(paths: list[str]) -> None:
    from shbake.bakers.shexp import FitConfig, FitPlan
    from shbake.envmap.environment import load_environment
    from shbake.evaluation.env_sh import CHECK_DIRECTIONS
    from shbake.sh.point_sets import fibonacci_sphere

    queries = fibonacci_sphere(CHECK_DIRECTIONS)
    plans = {}
    rows: dict[str, list[float]] = {}
    for path in paths:
        env = load_environment(path, quiet=True)
        if env.shape not in plans:
            plans[env.shape] = FitPlan(FitConfig(), env.shape)
        for name, ms in measure(env, plans[env.shape], queries).items():
            rows.setdefault(name, []).append(ms)
    print(f"{len(paths)} maps, CPU ms per map (best of {REPEATS}, mean over maps)")
    for name, values in rows.items():
        print(f"{name:28s} {np.mean(values):8.2f}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
