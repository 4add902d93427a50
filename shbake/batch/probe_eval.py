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
                 materials=MATERIALS):  # fmt: skip
    """Every case of one loaded map: rows (:func:`evaluate_cases`), the assets and their
    bytes per probe."""
    assets = bake_probes(env, plans, split_config, dfg)
    rows = evaluate_cases(env.pixels, assets, size, truth_samples, alphas, yaws, materials)
    return rows, assets, {name: probe_bytes(a) for name, a in assets.items()}
