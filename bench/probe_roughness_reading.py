"""probe-eval under both readings of the paper's roughness α (an experiment).

Usage: ``python bench/probe_roughness_reading.py [maps …]`` (default: the six shared maps)

Silvennoinen et al. write GGX in terms of α without saying whether it is the
microfacet width or the perceptual roughness whose square is that width
(CONVENTIONS, "Glossy probes"). shbake reads it as perceptual (width
``r²``). This script runs the probe-eval cases (32² spheres, 4096-sample
truth, default fit and split-sum) twice: as shipped, and with every GGX
width in the fit targets, the DFG table, the split-sum prefilter and the
truth set to ``r`` instead (by replacing ``ggx_alpha`` in this process only;
the plan cache is off so nothing leaks out). It prints SH-exp's wins per
roughness for each reading.
"""

import os
import sys
from pathlib import Path

import numpy as np

os.environ["SHBAKE_CACHE_DIR"] = "off"  # plans built here must not reach the cache

import shbake.probe.ggx_integrals as ggx_integrals  # noqa: E402
import shbake.probe.splitsum as splitsum  # noqa: E402
from shbake.envmap import load_environment  # noqa: E402
from shbake.probe.albedo_table import albedo_table  # noqa: E402
from shbake.probe.evaluation import ROUGHNESS, evaluate_map  # noqa: E402
from shbake.probe.shexp import FitConfig, FitPlan  # noqa: E402
from shbake.probe.splitsum import SplitSumConfig  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
READINGS = {
    "perceptual (width r², shipped)": ggx_integrals.ggx_alpha,
    "linear (width r)": lambda r: np.asarray(r, dtype=float),
}


def evaluate(names) -> dict:
    dfg = albedo_table()
    wins = {r: 0 for r in ROUGHNESS}
    total = {r: 0 for r in ROUGHNESS}
    for name in names:
        shared = ROOT.parent / "shared" / "hdri" / f"{name}.exr"
        path = shared if shared.exists() else ROOT / "data_samples" / f"{name}.exr"
        env = load_environment(str(path), quiet=True)
        rows, _, _ = evaluate_map(env, FitPlan(FitConfig(), env.shape), SplitSumConfig(), dfg)
        for row in rows:
            wins[row["roughness"]] += row["shexp_wins"]
            total[row["roughness"]] += 1
    return {r: (wins[r], total[r]) for r in ROUGHNESS}


def main():
    names = sys.argv[1:] or MAPS
    print("| reading of α | " + " | ".join(f"r {r:.2f}" for r in ROUGHNESS) + " | all |")
    print("|---|" + "---|" * (len(ROUGHNESS) + 1))
    for label, width in READINGS.items():
        ggx_integrals.ggx_alpha = splitsum.ggx_alpha = width
        counts = evaluate(names)
        w = sum(c[0] for c in counts.values())
        n = sum(c[1] for c in counts.values())
        cells = " | ".join(f"{a}/{b}" for a, b in counts.values())
        print(f"| {label} | {cells} | {w}/{n} ({w / n:.0%}) |", flush=True)


if __name__ == "__main__":
    main()
