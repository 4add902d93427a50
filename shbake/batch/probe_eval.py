"""``probe-eval``: bake both probes of a map and measure them against ground truth."""

from shbake.bakers.splitsum import prefilter_chain
from shbake.evaluation.probes import MATERIALS, ROUGHNESS, VIEW_YAWS, render_case
from shbake.format.shexp import build_shexp_asset
from shbake.format.splitsum import build_splitsum_asset


def evaluate_map(
    env,
    plan,
    split_config,
    dfg,
    size: int = 32,
    truth_samples: int = 4096,
    roughness=ROUGHNESS,
    yaws=VIEW_YAWS,
    materials=MATERIALS,
):
    """Every case of one loaded map; rows of dicts and the two probe assets."""
    shexp_asset = build_shexp_asset(plan.fit(env.pixels), plan.config, dfg, env.meta)
    chain = prefilter_chain(env.pixels, split_config)
    split_asset = build_splitsum_asset(chain, split_config, dfg, env.meta)
    rows = []
    for material, f0 in materials.items():
        for r in roughness:
            for yaw in yaws:
                renders = render_case(
                    env.pixels, shexp_asset, split_asset, r, f0, yaw, size, truth_samples
                )
                m_shexp, m_split = renders.mse()
                rows.append(
                    {
                        "material": material,
                        "roughness": float(r),
                        "yaw": float(yaw),
                        "mse_shexp": m_shexp,
                        "mse_splitsum": m_split,
                        "mse_truth_estimate": renders.truth_mse(),
                        "shexp_wins": m_shexp < m_split,
                    }
                )
    return rows, shexp_asset, split_asset
