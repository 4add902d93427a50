"""How many probe-eval cases can SH-exp win at all? An oracle fit per case.

Usage: ``python bench/probe_oracle_bound.py [maps …]`` (default: the six shared maps)

For every probe-eval case with roughness ≤ 0.6 (the cases split-sum wins),
``p`` and ``q`` (orders 4 and 2, 33 × 3 free numbers) are fitted to that
case's own ground-truth sphere — log-space least squares, then damped
Gauss–Newton on the case's linear MSE — and compared with split-sum's MSE.
This oracle sees the answer, so a case it loses cannot be won by any fit of
the default model (up to local minima of the Gauss–Newton steps). Prints
the cases lost per material and roughness and the largest winnable fraction.
"""

import sys
from pathlib import Path

import numpy as np

from shbake.envmap import load_environment
from shbake.probe.albedo_table import albedo_table, lookup
from shbake.probe.evaluation import MATERIALS, ROUGHNESS, VIEW_YAWS, sphere_views
from shbake.probe.ggx_integrals import ggx_integrals
from shbake.probe.probe_asset import build_splitsum_asset
from shbake.probe.shexp import design_rows
from shbake.probe.splitsum import SplitSumConfig, evaluate_splitsum, prefilter_chain

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
STEPS = 30


def oracle_mse(views, normals, roughness, f0, truth, dfg) -> float:
    """Smallest MSE of ``F0 E0 + (1 − F0) E0 A1/A0`` with ``E0 = P Q`` fitted to ``truth``."""
    A = design_rows(views, normals, np.full(len(views), roughness), 4, 2)
    albedo = lookup(dfg, np.einsum("ij,ij->i", views, normals), roughness)
    k = (f0 + (1.0 - f0) * albedo[:, 1] / albedo[:, 0])[:, None]
    x = np.linalg.lstsq(A, np.log(np.maximum(truth / k, 1e-6 * truth.mean())), rcond=None)[0]

    def mse(x):
        with np.errstate(over="ignore"):  # a trial step may overflow; it is then rejected
            return float(np.mean((k * np.exp(A @ x) - truth) ** 2))

    best = mse(x)
    for _ in range(STEPS):
        model = k * np.exp(A @ x)
        step = np.stack(
            [
                np.linalg.lstsq(A * model[:, c : c + 1], truth[:, c] - model[:, c], rcond=None)[0]
                for c in range(3)
            ],
            1,
        )
        for scale in 0.5 ** np.arange(14):
            trial = mse(x + scale * step)
            if np.isfinite(trial) and trial < best:
                x, best = x + scale * step, trial
                break
        else:
            break
    return best


def main():
    names = sys.argv[1:] or MAPS
    dfg, config = albedo_table(), SplitSumConfig()
    lost, total = {}, 0
    for name in names:
        shared = ROOT.parent / "shared" / "hdri" / f"{name}.exr"
        path = shared if shared.exists() else ROOT / "data_samples" / f"{name}.exr"
        env = load_environment(str(path), quiet=True)
        split = build_splitsum_asset(prefilter_chain(env.pixels, config), config, dfg, env.meta)
        levels = [split[f"/levels/{k}"] for k in range(config.levels)]
        for material, f0 in MATERIALS.items():
            for r in ROUGHNESS:
                for yaw in VIEW_YAWS:
                    total += 1
                    if r > 0.6:
                        continue
                    normals, view, _ = sphere_views(32, yaw)
                    views = np.broadcast_to(view, normals.shape)
                    e0, e1 = ggx_integrals(env.pixels, views, normals, r, 4096)
                    truth = f0 * e0 + (1.0 - f0) * e1
                    s = evaluate_splitsum(levels, split["/level_roughness"], dfg, views, normals,
                                          r, (f0,) * 3)  # fmt: skip
                    oracle = oracle_mse(np.asarray(views), normals, r, f0, truth, dfg)
                    key = (material, r)
                    lost[key] = lost.get(key, 0) + (oracle >= np.mean((s - truth) ** 2))
        print(f"{name}: done", file=sys.stderr, flush=True)
    print("| material | roughness | cases the oracle loses |")
    print("|---|---|---|")
    for (material, r), n in sorted(lost.items()):
        print(f"| {material} | {r:.2f} | {n}/{4 * len(names)} |")
    n_lost = sum(lost.values())
    print(f"\nAt most {total - n_lost}/{total} ({(total - n_lost) / total:.0%}) cases winnable.")


if __name__ == "__main__":
    main()
