"""The ``splitsum_probe`` asset (``docs/FORMAT.md`` §6)."""

import numpy as np

from shbake.format.asset import Asset
from shbake.format.probe import DFG_ATTRS, ROUGHNESS_CONVENTION, source_attrs


def build_splitsum_asset(levels, config, dfg: np.ndarray, meta: dict) -> Asset:
    """``/levels/k`` octahedral ``(size_k, size_k, 3)``, ``/level_roughness`` and ``/dfg``."""
    datasets = {f"/levels/{k}": np.asarray(lv, np.float32) for k, lv in enumerate(levels)}
    datasets["/level_roughness"] = config.roughness.astype(np.float64)
    datasets["/dfg"] = dfg.astype(np.float32)
    attrs = {
        "technique": "split-sum prefiltered octahedral mip chain (Karis 2013)",
        "roughness_convention": ROUGHNESS_CONVENTION,
        "roughness_range": [config.roughness_min, config.roughness_max],
        "levels": config.levels,
        "splitsum_config": config.as_dict(),
        "octahedral": "about +Y; p=(x,z)/(|x|+|y|+|z|), folded for y<0; (u,w)=(p+1)/2",
        **source_attrs(meta),
    }
    return Asset("splitsum_probe", attrs, datasets, {"/dfg": DFG_ATTRS})
