"""How far a single light's direction may be relaxed before three lights + L2 meet 1 %.

Usage: ``python bench/irradiance_light_caps.py [--radii 1 2 3 4] [MAP …]`` (default studio).

A branch and bound over the three lights' directions would bound each node — a cell of
directions per light — by the linear programme with *any number* of lights inside the
cells: that is what the cells allow once each light's direction is relaxed, and a cluster
of lights in a cell lights a probe as an area light does. This measures how small the
cells must be for that bound to clear the acceptance near the best fit known: around each
of the ``--lights 3`` directions, a cap of radius ``r`` holds every direction of a
``POOL``-point spherical-Fibonacci set (about 0.26° apart) as a light of free non-negative
luminance, and :func:`irradiance_lights.best_luminance_fit` gives the least mean relative
luminance error at the 2048 acceptance normals with every error ≤ 10 % (energy kept, the
SH part free of sign, as for the searches there). Below 1 %, such cells cannot be pruned.

Writes ``PREFIX.json`` and ``PREFIX.md`` (default ``bench/results/irradiance_light_caps``).
"""

import argparse

import irradiance_lights as lights
import numpy as np

POOL = 600_000


def measure(name: str, radii: list[float]) -> dict:
    from shbake.bakers import env_lights
    from shbake.sh.point_sets import fibonacci_sphere

    normals, ref_lum, energy, target = lights.acceptance_inputs(name)
    centres = env_lights.fit_lights(target, 3).directions
    pool = fibonacci_sphere(POOL)
    rows = []
    for r in radii:
        inside = (pool @ centres.T >= np.cos(np.radians(r))).any(axis=1)
        fit = lights.best_luminance_fit(pool[inside], normals, ref_lum, energy, "mean",
                                        lights.ACCEPT_MAX)  # fmt: skip
        rows.append({"radius_deg": r, "lights": int(inside.sum()), "least_mean_within_max": fit})
        print(name, rows[-1], flush=True)
    return {"centres": centres.round(4).tolist(), "caps": rows}


def markdown(results: dict) -> str:
    lines = ["| map | cap radius | lights in the caps | least mean with every error ≤ 10 % |",
             "|---|---|---|---|"]  # fmt: skip
    for m, r in results.items():
        for row in r["caps"]:
            w = row["least_mean_within_max"]
            w = "none" if w is None else f"{w['mean']:.2%} (max {w['max']:.1%})"
            lines.append(f"| {m} | {row['radius_deg']:g}° | {row['lights']} | {w} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("maps", nargs="*", default=["studio"])
    ap.add_argument("--radii", nargs="*", type=float, default=[1.0, 2.0, 3.0, 4.0])
    ap.add_argument("--out", default=str(lights.RESULTS / "irradiance_light_caps"))
    args = ap.parse_args()
    results = {m: measure(m, args.radii) for m in args.maps}
    lights.write_results(args.out, results, markdown(results))


if __name__ == "__main__":
    main()
