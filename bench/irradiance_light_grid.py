"""Three directional lights + L2 on night and studio: every triple of a direction grid.

Usage: ``python bench/irradiance_light_grid.py [--grid 1000] [--top 20000] [--refined 25]
[MAP …]`` (default night and studio, the maps where ``--lights 3`` misses 1 %).

``bench/irradiance_lights.py --search`` runs the ``--lights`` search from 61 random starts.
This one does not depend on starts: it scans **every** triple of a ``--grid``-point
spherical-Fibonacci direction set (1000 points: 166 million triples, about 6° apart) and
ranks each by the least relative squared error at the 2048 acceptance normals that 9 free
coefficients + 3 non-negative lights at those directions give (the SH part projected out,
the lights' non-negative least squares solved exactly over every support; checked first
against SciPy's NNLS on every triple of a 30-point grid, :func:`check_scan`). Of the
``--top`` best triples, the ``--refined`` best distinct ones (no two within 0.3 summed
distance, antipodes counted as equal: ``max(0, n·d) − max(0, −n·d) = n·d`` lies in L1)
are refined: their directions by least squares on the relative error, then by iteratively
reweighted least squares toward the mean relative error. At the grid triple and at both
refinements, :func:`irradiance_lights.best_luminance_fit` gives the least mean error any
fit there can have, the least max, and the least mean with every error ≤ 10 %.

Writes ``PREFIX.json`` and ``PREFIX.md`` (default ``bench/results/irradiance_light_grid``).
"""

import numpy as np
from irradiance_lights import (
    ACCEPT_MAX,
    acceptance_inputs,
    best_luminance_fit,
    missed_maps_parser,
    write_results,
)

IRLS_STEPS = 6
IRLS_FLOOR = 2e-3
DISTINCT = 0.3


def relative_design(normals, ref_lum, dirs):
    """SH-free parts of the relative residual: ``(target, kernels)``, the L2 basis projected
    out of the constant target ``1`` and of each light's ``max(0, n·d)/Y``."""
    from shbake.sh.basis import real_sh

    q, _ = np.linalg.qr(real_sh(normals, 2) / ref_lum[:, None])
    one = np.ones(len(ref_lum))
    kernels = np.maximum(normals @ dirs.T, 0.0) / ref_lum[:, None]
    return one - q @ (q.T @ one), kernels - q @ (q.T @ kernels)


def _pair(gi, gj, a, b, d):
    det = a * b - d * d
    with np.errstate(divide="ignore", invalid="ignore"):
        xi, xj = (b * gi - d * gj) / det, (a * gj - d * gi) / det
        red = gi * xi + gj * xj
    return np.where((det > 1e-12 * a * b) & (xi >= 0) & (xj >= 0), red, -np.inf)


def scan(gram: np.ndarray, g: np.ndarray, top: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``top`` triples ``i < j < l`` with the largest non-negative least-squares
    reduction ``g_Sᵀ G_S⁻¹ g_S`` (the best support ``S`` of the three), best first."""
    m = len(g)
    jj, ll = np.triu_indices(m, 1)
    diag = np.diag(gram)
    single = np.where(g > 0, g * g / diag, 0.0)
    best_red, best_idx = np.full(0, -np.inf), np.zeros((0, 3), int)
    for i in range(m - 2):
        keep = jj > i
        j, l = jj[keep], ll[keep]
        a, b, c = diag[i], diag[j], diag[l]
        d, e, f = gram[i, j], gram[i, l], gram[j, l]
        gi, gj, gl = g[i], g[j], g[l]
        c00, c01, c02 = b * c - f * f, e * f - d * c, d * f - b * e
        c11, c12, c22 = a * c - e * e, d * e - a * f, a * b - d * d
        det = a * c00 + d * c01 + e * c02
        with np.errstate(divide="ignore", invalid="ignore"):
            xi = (c00 * gi + c01 * gj + c02 * gl) / det
            xj = (c01 * gi + c11 * gj + c12 * gl) / det
            xl = (c02 * gi + c12 * gj + c22 * gl) / det
        ok = (det > 1e-12 * a * b * c) & (xi >= 0) & (xj >= 0) & (xl >= 0)
        red = np.where(ok, gi * xi + gj * xj + gl * xl, -np.inf)
        red = np.maximum.reduce([red, _pair(gi, gj, a, b, d), _pair(gi, gl, a, c, e),
                                 _pair(gj, gl, b, c, f), single[j], single[l],
                                 np.full(len(j), single[i])])  # fmt: skip
        if len(red) > top:
            part = np.argpartition(-red, top)[:top]
            red, j, l = red[part], j[part], l[part]
        best_red = np.concatenate([best_red, red])
        best_idx = np.concatenate([best_idx, np.stack([np.full(len(j), i), j, l], 1)])
        order = np.argsort(-best_red)[:top]
        best_red, best_idx = best_red[order], best_idx[order]
    return best_idx, best_red


def check_scan(normals, ref_lum, points: int = 30, top: int = 20) -> None:
    """:func:`scan` against SciPy's NNLS on every triple of a small grid (run first)."""
    from itertools import combinations

    from scipy.optimize import nnls

    from shbake.sh.point_sets import fibonacci_sphere

    target, kernels = relative_design(normals, ref_lum, fibonacci_sphere(points))
    reductions = []
    for t in combinations(range(points), 3):
        reductions.append(target @ target - nnls(kernels[:, t], target)[1] ** 2)
    _, red = scan(kernels.T @ kernels, kernels.T @ target, top)
    if not np.allclose(red, np.sort(reductions)[::-1][:top], rtol=1e-6):
        raise SystemExit("scan disagrees with scipy.optimize.nnls")


def distinct(triples: list[np.ndarray], count: int) -> list[np.ndarray]:
    """The first ``count`` triples not within :data:`DISTINCT` of an earlier one."""
    kept: list[np.ndarray] = []
    for t in triples:
        if len(kept) == count:
            break
        if all(sum(np.min(1.0 - np.abs(k @ d)) for d in t) > DISTINCT**2 / 2 for k in kept):
            kept.append(t)
    return kept


def refine(dirs, normals, ref_lum):
    """``(least-squares directions, IRLS directions)`` of the relative error from ``dirs``."""
    from scipy.optimize import least_squares, nnls

    from shbake.bakers import env_lights

    frames = env_lights._frames(dirs)

    def residual(x, w):
        target, kernels = relative_design(normals, ref_lum, env_lights._directions(x, frames))
        c, _ = nnls(kernels * w[:, None], target * w)
        return (kernels @ c - target) * w

    x, w, refined = np.tile([np.pi / 2.0, 0.0], len(dirs)), np.ones(len(ref_lum)), []
    for _ in range(IRLS_STEPS):
        x = least_squares(residual, x, args=(w,), method="trf", diff_step=1e-4).x
        refined.append(env_lights._directions(x, frames))
        rel = np.abs(residual(x, np.ones(len(ref_lum))))
        w = 1.0 / np.sqrt(np.maximum(rel, IRLS_FLOOR))
    return refined[0], refined[-1]


def bounds(dirs, normals, ref_lum, energy) -> dict:
    """The linear programmes' least mean, least max and least mean within the max at ``dirs``."""
    return {
        "dirs": dirs.round(4).tolist(),
        "least_mean": best_luminance_fit(dirs, normals, ref_lum, energy, "mean"),
        "least_max": best_luminance_fit(dirs, normals, ref_lum, energy, "max"),
        "least_mean_within_max": best_luminance_fit(dirs, normals, ref_lum, energy, "mean",
                                                    ACCEPT_MAX),
    }  # fmt: skip


def measure(name: str, grid: int, top: int, refined: int) -> dict:
    from shbake.sh.point_sets import fibonacci_sphere

    normals, ref_lum, energy, _ = acceptance_inputs(name)
    check_scan(normals, ref_lum)
    points = fibonacci_sphere(grid)
    target, kernels = relative_design(normals, ref_lum, points)
    idx, _ = scan(kernels.T @ kernels, kernels.T @ target, top)
    rows = []
    for t in distinct([points[i] for i in idx], refined):
        sets = dict(zip(("grid", "least_squares", "irls"), (t, *refine(t, normals, ref_lum)),
                        strict=True))  # fmt: skip
        rows.append({k: bounds(d, normals, ref_lum, energy) for k, d in sets.items()})
        print(name, len(rows), {k: round(v["least_mean"]["mean"] * 100, 3) for k, v in
                                rows[-1].items()}, flush=True)  # fmt: skip
    every = [v for r in rows for v in r.values()]
    within = [v["least_mean_within_max"] for v in every if v["least_mean_within_max"]]
    return {
        "grid": grid, "triples": grid * (grid - 1) * (grid - 2) // 6, "refined": len(rows),
        "least_mean": min((v["least_mean"] for v in every), key=lambda e: e["mean"]),
        "least_max": min((v["least_max"] for v in every), key=lambda e: e["max"]),
        "least_mean_within_max": min(within, key=lambda e: e["mean"]) if within else None,
        "sets": rows,
    }  # fmt: skip


def markdown(results: dict) -> str:
    lines = ["| map | grid points (triples) | triples refined | least mean any fit gives "
             "| least max any fit gives | least mean with every error ≤ 10 % |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for m, r in results.items():
        a, b, w = r["least_mean"], r["least_max"], r["least_mean_within_max"]
        w = "none at any direction set" if w is None else f"{w['mean']:.2%}"
        lines.append(f"| {m} | {r['grid']} ({r['triples']:,}) | {r['refined']} | "
                     f"{a['mean']:.2%} (max {a['max']:.1%}) | {b['max']:.1%} (mean "
                     f"{b['mean']:.2%}) | {w} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def main():
    ap = missed_maps_parser(__doc__, "irradiance_light_grid")
    ap.add_argument("--grid", type=int, default=1000)
    ap.add_argument("--top", type=int, default=20000)
    ap.add_argument("--refined", type=int, default=25)
    args = ap.parse_args()
    results = {m: measure(m, args.grid, args.top, args.refined) for m in args.maps}
    write_results(args.out, results, markdown(results))


if __name__ == "__main__":
    main()
