"""Fit targets: error and time of the two ways to compute ``E0`` at the fit samples.

Usage: ``python bench/probe_targets.py [maps …]`` (default: the six shared maps)

For the default fit samples (64 normals × 32 views × 8 α), every
7th target is integrated with 65 536 plain visible-normal samples (the
ground truth, :func:`shbake.reference.ggx.ggx_integrals`). Against it:
the filtered quadrature plan (1024 samples, the default targets) and the SH
fast path (``--targets sh``) at lmax 4, 8 and 16. Error: RMS of
``log(E0 / truth)`` per fit α (the fit works in log space; values
below the fit's floor are floored first). Time: one probe's targets, after
warm-up, numba on all cores.
"""

import sys
import time
from pathlib import Path

import numpy as np

from shbake.bakers.shexp import FitConfig, FitPlan
from shbake.bakers.shexp_sh_targets import ShTargets
from shbake.envmap import load_environment
from shbake.reference.ggx import ggx_integrals

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")


def timed(fn, *args):
    fn(*args)
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def main():
    names = sys.argv[1:] or MAPS
    cfg = FitConfig()
    head = " | ".join(f"α {r:.2f}" for r in cfg.alphas)
    print(f"| map | targets | ms | {head} |")
    print("|---|---|---|" + "---|" * len(cfg.alphas))
    for name in names:
        shared = ROOT.parent / "shared" / "hdri" / f"{name}.exr"
        path = shared if shared.exists() else ROOT / "data_samples" / f"{name}.exr"
        env = load_environment(str(path), quiet=True)
        plan = FitPlan(cfg, env.shape)
        sel = np.arange(0, plan.views.shape[0], 7)
        truth, _ = ggx_integrals(
            env.pixels, plan.views[sel], plan.normals[sel], plan.alpha[sel], 1 << 16
        )
        floor = cfg.floor * truth.mean(0)
        rows = [("quadrature 1024", plan.targets)]
        rows += [
            (f"sh lmax {lmax}", ShTargets(plan.views, plan.normals, plan.alpha, lmax))
            for lmax in (4, 8, 16)
        ]
        for label, targets in rows:
            e0, seconds = timed(targets.e0, env.pixels)
            err = np.log(np.maximum(e0[sel], floor) / truth)
            cells = " | ".join(
                f"{np.sqrt(np.mean(err[plan.alpha[sel] == r] ** 2)):.3g}" for r in cfg.alphas
            )
            print(f"| {name} | {label} | {seconds * 1e3:.1f} | {cells} |", flush=True)


if __name__ == "__main__":
    main()
