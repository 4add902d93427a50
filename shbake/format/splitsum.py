"""The ``splitsum_probe`` asset (``docs/FORMAT.md`` §3, kind ``splitsum_probe``), probe format 2."""

import numpy as np

from shbake.errors import FormatError
from shbake.format.asset import Asset
from shbake.format.probe import (
    DFG_ATTRS,
    DFG_DATA,
    PROBE_ATTRS,
    check_alpha_range,
    convention_attrs,
    source_attrs,
)
from shbake.format.registry import MAP_KIND_ATTRS, Attr, Data, Kind, register

LEVELS_MAX = 16
SIZE_MAX = 4096


def _check(attrs, shapes, dattrs, symbols):
    check_alpha_range(attrs)
    for k in range(attrs["levels"]):
        size = shapes[f"/levels/{k}"][0]
        if not 1 <= size <= SIZE_MAX:
            raise FormatError(f"dataset /levels/{k}: size {size} outside [1, {SIZE_MAX}]")


def _check_alphas(values):
    if np.any(np.diff(values) <= 0) or np.any(values < 0) or np.any(values > 1):
        raise FormatError("dataset /level_alpha must increase within [0, 1]")


SPLITSUM_PROBE = register(Kind(
    name="splitsum_probe",
    version=2,
    title="split-sum prefiltered octahedral mip chain (Karis 2013; `split-sum`)",
    attrs=PROBE_ATTRS + MAP_KIND_ATTRS + (
        Attr("levels", "int", "prefiltered levels, one per GGX width", range=(1, LEVELS_MAX),
             symbol="levels"),
        Attr("prefilter", "str", "`plain` (Karis 2013) or `filtered` (filtered importance "
             "sampling)"),
        Attr("splitsum_config", "json", "every prefilter option", json_type=dict),
        Attr("octahedral", "str", "the octahedral parameterisation (about +Y, CONVENTIONS)"),
    ),
    datasets=(
        Data("/levels/{k}", ("S", "S", 3), "float32",
             "level `k` (0 … levels−1), prefiltered at GGX width `/level_alpha[k]`"),
        Data("/level_alpha", ("levels",), "float64", "GGX width of each level, increasing",
             values=_check_alphas),
        DFG_DATA,
    ),
    members=lambda spec, attrs, dattrs: [f"/levels/{k}" for k in range(attrs["levels"])],
    check=_check,
))  # fmt: skip


def build_splitsum_asset(levels, config, dfg: np.ndarray, meta: dict) -> Asset:
    """``/levels/k`` octahedral ``(size_k, size_k, 3)``, ``/level_alpha`` and ``/dfg``."""
    datasets = {f"/levels/{k}": np.asarray(lv, np.float32) for k, lv in enumerate(levels)}
    datasets["/level_alpha"] = np.asarray(config.alphas, np.float64)
    datasets["/dfg"] = dfg.astype(np.float32)
    attrs = convention_attrs(config.alpha_range) | {
        "technique": f"split-sum prefiltered octahedral mip chain (Karis 2013), "
        f"{config.prefilter} prefilter",
        "levels": config.levels,
        "prefilter": config.prefilter,
        "splitsum_config": config.as_dict(),
        "octahedral": "about +Y; p=(x,z)/(|x|+|y|+|z|), folded for y<0; (u,w)=(p+1)/2",
        **source_attrs(meta),
    }
    return Asset("splitsum_probe", attrs, datasets, {"/dfg": DFG_ATTRS})
