"""SH-exp fit variants: error against bytes per probe on the 288 shared-map cases.

Usage: ``SHBAKE_TRUTH_CACHE=DIR python bench/probe_variants.py [--out PREFIX]``

Each variant (a :class:`~shbake.bakers.shexp.FitConfig`) is fitted to the six shared maps
and written as the probe asset an engine receives (:func:`~shbake.format.shexp.build_shexp_asset`,
float32), shaded by the registry's shader (:func:`shbake.shading.shader.shader`) on the cases of
``bench/probe_eval.py`` (2 materials × the paper's six α × 4 views per map, 32² spheres,
MIS ground truth at 2048 samples: :func:`~shbake.evaluation.probes.case_truth`, the same
truths, cached with ``SHBAKE_TRUTH_CACHE``) and compared with the plain split-sum's MSE of
``bench/results/probe_eval.json`` (the default variant's MSEs are checked against that
file's ``shexp_v2``). Reported per variant: bytes per probe, wins against the plain
split-sum (all, chrome, dielectric, dielectric at α ≤ 0.36), median MSE ratio to it, and
the fit's CPU time per probe in this process (numba on one thread; targets excluded).

Writes ``PREFIX.json``, ``PREFIX.md`` and ``PREFIX.png`` (wins and median MSE ratio vs bytes);
default prefix ``bench/results/probe_variants``.
"""

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
HDRI = ROOT.parent / "shared" / "hdri"
RESULTS = ROOT / "bench" / "results"
SIZE, TRUTH_SAMPLES = 32, 2048


def variants():
    from shbake.bakers.shexp import FitConfig

    return {
        "paper (1 set, lmax 4/2)": FitConfig.paper(),
        "1 set, lmax 5/2, default fit": FitConfig(sets=1),
        "issue 12 default (lmax 4/2, 64 normals, 1 polish step)": FitConfig(
            lmax_p=4, normals=64, polish=1, alpha_weight=0.0
        ),
        "default without the α weight (alpha_weight 0)": FitConfig(alpha_weight=0.0),
        "α weight 0.5, else default": FitConfig(alpha_weight=0.5),
        "default (lmax 5/2, 48 normals, 2 polish steps, α weight 1)": FitConfig(),
        "α weight 2, else default": FitConfig(alpha_weight=2.0),
        "3 sets, lmax 4/2": FitConfig(sets=3, lmax_p=4, normals=64, polish=1),
        "lmax 6/2": FitConfig(lmax_p=6),
        "first knot 0.15, else default": FitConfig(alpha_min=0.15),
        "first knot 0.1, else default": FitConfig(alpha_min=0.1),
        "Fresnel-aware weights (shaded-nv-f0), else default": FitConfig(weights="shaded-nv-f0"),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RESULTS / "probe_variants"))
    args = ap.parse_args()
    from shbake.jit import use_one_thread

    use_one_thread()
    from shbake.batch.probe_jobs import fit_plan, shared_dfg_table
    from shbake.envmap import load_environment
    from shbake.evaluation.metrics import mean_squared_error
    from shbake.evaluation.probes import ALPHAS, MATERIALS, VIEW_YAWS, case_truth
    from shbake.format.probe import probe_bytes
    from shbake.format.shexp import build_shexp_asset
    from shbake.shading.shader import shader

    stored = json.loads((RESULTS / "probe_eval.json").read_text())
    dfg = shared_dfg_table()
    cache = os.environ.get("SHBAKE_TRUTH_CACHE")
    out = {name: {"cases": [], "bytes": None, "fit_ms": []} for name in variants()}
    check = 0.0
    for m in MAPS:
        env = load_environment(str(HDRI / f"{m}.exr"), quiet=True)
        truths = {(a, y): case_truth(env.pixels, a, y, SIZE, TRUTH_SAMPLES, cache)
                  for a in ALPHAS for y in VIEW_YAWS}  # fmt: skip
        base = {(r["material"], r["alpha"], r["yaw"]): r["mse"] for r in stored["maps"][m]}
        for name, cfg in variants().items():
            plan = fit_plan(cfg, env.shape)
            e0 = plan.targets.e0(env.pixels)
            t0 = time.process_time()
            probe = plan.fit_targets(e0)
            out[name]["fit_ms"].append(1e3 * (time.process_time() - t0))
            asset = build_shexp_asset(probe, cfg, dfg, env.meta)
            out[name]["bytes"] = probe_bytes(asset)
            for (a, y), t in truths.items():
                for material, f0 in MATERIALS.items():
                    shaded = shader(asset).shade(t.normals, t.views, alpha=a, f0=f0)
                    mse = mean_squared_error(shaded, t.radiance(f0))
                    ref = base[(material, a, y)]
                    out[name]["cases"].append(
                        {
                            "map": m,
                            "material": material,
                            "alpha": a,
                            "yaw": y,
                            "mse": mse,
                            "splitsum_plain": ref["splitsum_plain"],
                        }  # fmt: skip
                    )
                    if name.startswith("default ("):
                        check = max(check, abs(mse / ref["shexp_v2"] - 1.0))
        print(m, flush=True)
    summary = {}
    for name, r in out.items():
        c = r["cases"]
        win = [x["mse"] < x["splitsum_plain"] for x in c]
        ratio = [x["mse"] / x["splitsum_plain"] for x in c]

        def wins(pred, c=c, win=win):
            return int(sum(w for x, w in zip(c, win, strict=True) if pred(x)))

        summary[name] = {
            "bytes": r["bytes"],
            "wins": int(sum(win)),
            "chrome": wins(lambda x: x["material"] == "chrome"),
            "dielectric": wins(lambda x: x["material"] == "dielectric"),
            "dielectric_low": wins(lambda x: x["material"] == "dielectric" and x["alpha"] <= 0.36),
            "median_ratio": float(np.median(ratio)),
            "fit_ms": float(np.median(r["fit_ms"])),
        }
    result = {"variants": summary, "default_vs_probe_eval_json": check, "cases": out}
    Path(args.out + ".json").write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    lines = ["| variant | bytes/probe | wins of 288 | chrome of 144 | dielectric of 144 | "
             "dielectric α ≤ 0.36 of 48 | median MSE / split-sum | fit CPU ms |",
             "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for name, v in summary.items():
        lines.append(f"| {name} | {v['bytes']} | {v['wins']} | {v['chrome']} | "
                     f"{v['dielectric']} | {v['dielectric_low']} | {v['median_ratio']:.3f} | "
                     f"{v['fit_ms']:.1f} |")  # fmt: skip
    lines += ["", f"plain split-sum: 294912 bytes; default's MSEs vs probe_eval.json: max "
              f"relative difference {check:.1e}"]  # fmt: skip
    report = "\n".join(lines) + "\n"
    Path(args.out + ".md").write_text(report)
    plot(summary, args.out + ".png")
    print(report)


def plot(summary: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, v in summary.items():
        for ax, y in zip(axes, (100 * v["wins"] / 288, v["median_ratio"]), strict=True):
            ax.plot(v["bytes"], y, "o")
            ax.annotate(name.split(" (")[0], (v["bytes"], y), fontsize=7,
                        xytext=(4, 3), textcoords="offset points")  # fmt: skip
    axes[0].axhline(95, color="k", ls="--", lw=0.8)
    axes[0].set_ylabel("wins against the plain split-sum, % of 288")
    axes[1].set_ylabel("median MSE / plain split-sum MSE")
    axes[1].set_yscale("log")
    for ax in axes:
        ax.axvline(1200, color="grey", ls=":", lw=0.8)
        ax.set_xlabel("bytes per probe (float32; split-sum plain: 294 912)")
        ax.grid(True, alpha=0.3)
    fig.suptitle("SH-exp variants on the 288 shared-map cases (probe assets vs MIS truth)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
