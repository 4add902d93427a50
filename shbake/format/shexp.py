"""The ``shexp_probe`` and ``shexp_probe_set`` assets (``docs/FORMAT.md`` §5, §5a)."""

import json

import numpy as np

from shbake.errors import ParameterError
from shbake.format.asset import Asset
from shbake.format.probe import DFG_ATTRS, ROUGHNESS_CONVENTION, source_attrs

SHEXP_ATTRS = (
    "technique", "roughness_convention", "roughness_range", "lmax_p", "lmax_q", "fit_config",
    "fresnel_tail",
)  # fmt: skip


def _shexp_attrs(config) -> dict:
    """Root attributes every SH-exp kind shares (FORMAT §5)."""
    return {
        "technique": "SH exponential (Silvennoinen et al. 2025)",
        "roughness_convention": ROUGHNESS_CONVENTION,
        "roughness_range": [config.roughness_min, config.roughness_max],
        "lmax_p": config.lmax_p,
        "lmax_q": config.lmax_q,
        "fit_config": config.as_dict(),
        "fresnel_tail": "E1 = E0 * A1/A0 (eq. 15, exact under constant light)",
    }


def build_shexp_asset(probe, config, dfg: np.ndarray, meta: dict) -> Asset:
    """``/p`` ``(n_p, 3)``, ``/q`` ``(n_q − 1, 3)`` float32 and ``/dfg``."""
    attrs = _shexp_attrs(config) | {"fit_stats": probe.stats, **source_attrs(meta)}
    return Asset(
        "shexp_probe",
        attrs,
        {
            "/p": probe.p.astype(np.float32),
            "/q": probe.q.astype(np.float32),
            "/dfg": dfg.astype(np.float32),
        },
        {
            "/dfg": DFG_ATTRS,
            "/p": {"axes": ["coeff", "channel"]},
            "/q": {"axes": ["coeff", "channel"]},
        },
    )


def build_shexp_set_asset(probes: list[dict], config, dfg: np.ndarray) -> Asset:
    """Many SH-exp probes in one file: ``/p`` ``(N, n_p, 3)``, ``/q`` ``(N, n_q − 1, 3)``,
    one ``/dfg``. ``probes``: per probe ``{"name", "p", "q", "stats", "meta"}`` in set order."""
    attrs = _shexp_attrs(config) | {
        "probe_count": len(probes),
        "probe_names": [x["name"] for x in probes],
        "probe_sources": [source_attrs(x["meta"]) for x in probes],
        "probe_fit_stats": [x["stats"] for x in probes],
    }
    return Asset(
        "shexp_probe_set",
        attrs,
        {
            "/p": np.stack([x["p"] for x in probes]).astype(np.float32),
            "/q": np.stack([x["q"] for x in probes]).astype(np.float32),
            "/dfg": dfg.astype(np.float32),
        },
        {
            "/dfg": DFG_ATTRS,
            "/p": {"axes": ["probe", "coeff", "channel"]},
            "/q": {"axes": ["probe", "coeff", "channel"]},
        },
    )


def probe_from_set(asset: Asset, index: int) -> Asset:
    """Probe ``index`` of a ``shexp_probe_set`` as an in-memory ``shexp_probe``."""
    count = int(asset.attrs["probe_count"])
    if not 0 <= index < count:
        raise ParameterError(f"probe index {index} is outside this set of {count} probes")
    sources = asset.attrs["probe_sources"]
    source = (json.loads(sources) if isinstance(sources, str) else sources)[index]
    attrs = {k: asset.attrs[k] for k in SHEXP_ATTRS} | source
    datasets = {"/p": asset["/p"][index], "/q": asset["/q"][index], "/dfg": asset["/dfg"]}
    return Asset("shexp_probe", attrs, datasets)
