"""``probe-eval``: bake every probe under test for a map and measure them against ground truth.

Probes under test (:data:`EVALUATED`): SH-exp v2 (the default fit), the
paper's SH-exp (``--sets 1 --weights log``), the paper's plain split-sum
(1024 samples per texel, levels at the evaluated ``α``) and the engine-grade
split-sum (filtered importance sampling, same levels).
"""

from dataclasses import replace

from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
from shbake.evaluation.probes import ALPHAS, MATERIALS, VIEW_YAWS, evaluate_cases
from shbake.format.probe import probe_bytes
from shbake.format.shexp import build_shexp_asset
from shbake.format.splitsum import build_splitsum_asset

EVALUATED = ("shexp_v2", "shexp_paper", "splitsum_plain", "splitsum_filtered")


def bake_probes(env, plans: dict, split_config: SplitSumConfig, dfg) -> dict:
    """The probe assets of one loaded map: ``plans`` name → :class:`FitPlan` for the
    SH-exp probes; both split-sum prefilters of ``split_config``."""
    assets = {name: build_shexp_asset(plan.fit(env.pixels), plan.config, dfg, env.meta)
              for name, plan in plans.items()}  # fmt: skip
    for prefilter in ("plain", "filtered"):
        cfg = replace(split_config, prefilter=prefilter)
        chain = prefilter_chain(env.pixels, cfg)
        assets[f"splitsum_{prefilter}"] = build_splitsum_asset(chain, cfg, dfg, env.meta)
    return assets


def evaluate_map(env, plans: dict, split_config: SplitSumConfig, dfg, size: int = 32,
                 truth_samples: int = 4096, alphas=ALPHAS, yaws=VIEW_YAWS,
                 materials=MATERIALS, cache_dir=None, sheet_dir=None, label="map"):  # fmt: skip
    """Every case of one loaded map: rows (:func:`evaluate_cases`), the assets and their
    bytes per probe; ``sheet_dir``: one contact sheet per case, named after ``label``."""
    assets = bake_probes(env, plans, split_config, dfg)
    rows = evaluate_cases(env.pixels, assets, size, truth_samples, alphas, yaws, materials,
                          cache_dir, sheet_dir, label)  # fmt: skip
    return rows, assets, {name: probe_bytes(a) for name, a in assets.items()}


def evaluate_maps(paths, size: int = 32, truth_samples: int = 4096, progress=None,
                  cache_dir=None, sheet_dir=None) -> dict:  # fmt: skip
    """Every case of every map (lat-long files): ``{"maps": {stem: rows}, "bytes": {name:
    bytes per probe}, "configs": …}``; SH-exp v2 is :class:`FitConfig` ``()``, the paper's
    fit :meth:`FitConfig.paper`, both split-sums :class:`SplitSumConfig` ``()`` (plain and
    filtered)."""
    from pathlib import Path

    from shbake.bakers.shexp import FitConfig
    from shbake.batch.probe_jobs import fit_plan, shared_dfg_table
    from shbake.envmap import load_environment
    from shbake.errors import InputError

    dfg = shared_dfg_table()
    split = SplitSumConfig()
    configs = {"shexp_v2": FitConfig(), "shexp_paper": FitConfig.paper()}
    out = {"maps": {}, "bytes": {}, "size": size, "truth_samples": truth_samples,
           "configs": {k: c.as_dict() for k, c in configs.items()} | {
               "splitsum": split.as_dict()}}  # fmt: skip
    for path in paths:
        env = load_environment(str(path), quiet=True)
        if env.layout != "latlong":
            raise InputError(f"{path}: probe-eval takes lat-long maps (2:1)")
        plans = {k: fit_plan(c, env.shape) for k, c in configs.items()}
        if sheet_dir is not None:
            Path(sheet_dir).mkdir(parents=True, exist_ok=True)
        rows, _, nbytes = evaluate_map(env, plans, split, dfg, size, truth_samples,
                                       cache_dir=cache_dir, sheet_dir=sheet_dir,
                                       label=Path(path).stem)  # fmt: skip
        out["maps"][Path(path).stem] = rows
        out["bytes"] = nbytes
        if progress:
            progress(Path(path).stem, rows)
    return out


def win_table(result: dict, method: str, baseline: str) -> dict:
    """Wins of ``method`` over ``baseline``: per (material, α) and per (map, material, α),
    and in total, as ``(wins, cases)`` pairs; ties (MSE difference below the truth's own
    error estimate) are counted apart."""
    cell, by_map, total, ties = {}, {}, [0, 0], 0
    for name, rows in result["maps"].items():
        for r in rows:
            win = r["mse"][method] < r["mse"][baseline]
            key = (r["material"], r["alpha"])
            for table, k in ((cell, key), (by_map, (name, *key))):
                w, n = table.get(k, (0, 0))
                table[k] = (w + win, n + 1)
            total = [total[0] + win, total[1] + 1]
            ties += abs(r["mse"][method] - r["mse"][baseline]) < r["mse_truth_estimate"]
    return {"cells": cell, "by_map": by_map, "total": tuple(total), "ties": ties}


COMPARISONS = (("shexp_v2", "splitsum_plain"), ("shexp_v2", "splitsum_filtered"),
               ("shexp_paper", "splitsum_plain"), ("shexp_paper", "splitsum_filtered"))


def markdown_report(result: dict) -> str:
    """Win rates per α and material for :data:`COMPARISONS`, bytes per probe, and the full
    per-map table and case list."""
    tables = {c: win_table(result, *c) for c in COMPARISONS}
    keys = sorted(next(iter(tables.values()))["cells"])
    head = " | ".join(f"{m} vs {b}" for m, b in COMPARISONS)
    lines = [f"| material | α | {head} |", "|---|---|" + "---|" * len(COMPARISONS)]
    for k in keys:
        cells = " | ".join("{}/{}".format(*tables[c]["cells"][k]) for c in COMPARISONS)
        lines.append(f"| {k[0]} | {k[1]:.4g} | {cells} |")
    totals = []
    for c in COMPARISONS:
        w, n = tables[c]["total"]
        totals.append(f"**{w}/{n} ({100 * w / n:.1f} %)**")
    lines.append(f"| all | all | {' | '.join(totals)} |")
    lines += ["", "ties (|ΔMSE| below the truth's own error estimate): "
              + ", ".join(f"{m} vs {b}: {tables[(m, b)]['ties']}" for m, b in COMPARISONS)]
    lines += ["", "| probe | bytes per probe |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in result["bytes"].items()]
    lines += ["", "Per map (wins of v2 vs plain / v2 vs filtered / paper vs plain / "
              "paper vs filtered, out of 4 views):", "",
              "| map | material | α | wins |", "|---|---|---|---|"]  # fmt: skip
    for k in sorted(next(iter(tables.values()))["by_map"]):
        cells = " / ".join(str(tables[c]["by_map"][k][0]) for c in COMPARISONS)
        lines.append(f"| {k[0]} | {k[1]} | {k[2]:.4g} | {cells} |")
    lines += ["", "Cases (MSE):", "",
              "| map | material | α | yaw | v2 | paper | split-sum plain | split-sum filtered "
              "| truth error (est.) |", "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for name, rows in result["maps"].items():
        for r in rows:
            m = r["mse"]
            lines.append(
                f"| {name} | {r['material']} | {r['alpha']:.4g} | {r['yaw']:.0f} | "
                f"{m['shexp_v2']:.3e} | {m['shexp_paper']:.3e} | {m['splitsum_plain']:.3e} | "
                f"{m['splitsum_filtered']:.3e} | {r['mse_truth_estimate']:.1e} |"
            )
    return "\n".join(lines) + "\n"


def bake_splitsum_file(source, output, top=128, min_size=32, alphas=None, prefilter="plain",
                       samples=1024, negative="clamp", fix_nonfinite=None) -> dict:  # fmt: skip
    """``split-sum``: read a lat-long map, prefilter its chain, write the asset; a summary."""
    from shbake.bakers.splitsum import PAPER_ALPHAS
    from shbake.batch.probe_jobs import shared_dfg_table
    from shbake.envmap import load_environment
    from shbake.errors import InputError
    from shbake.format.asset import write_asset
    from shbake.format.atomic import check_output_path

    config = SplitSumConfig(top, min_size, tuple(alphas or PAPER_ALPHAS), samples, prefilter)
    check_output_path(output)
    env = load_environment(source, negative=negative, fix_nonfinite=fix_nonfinite, quiet=True)
    if env.layout != "latlong":
        raise InputError(f"{source}: split-sum takes lat-long maps (2:1), got {env.layout}")
    asset = build_splitsum_asset(prefilter_chain(env.pixels, config), config, shared_dfg_table(),
                                 env.meta)  # fmt: skip
    write_asset(output, asset)
    return {"output": output, "levels": config.levels, "bytes": probe_bytes(asset),
            "config": config.as_dict()}  # fmt: skip
