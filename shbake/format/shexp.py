"""The ``shexp_probe`` and ``shexp_probe_set`` assets (``docs/FORMAT.md`` §5, §5a), probe format 2.

``/p`` ``(K, (lmax_p+1)², 3)`` and ``/q`` ``(K, (lmax_q+1)² − 1, 3)`` float32: ``K``
coefficient sets at the GGX widths ``/knots`` ``(K,)`` (float64), blended by
hat functions of ``α`` (:mod:`shbake.shading.shexp`); sets gain a leading
probe axis.
"""

import json

import numpy as np

from shbake.errors import ParameterError
from shbake.format.asset import Asset
from shbake.format.probe import DFG_ATTRS, convention_attrs, source_attrs

SHEXP_ATTRS = (
    "technique", "probe_format", "alpha_convention", "alpha_convention_text", "alpha_range",
    "lmax_p", "lmax_q", "sets", "weights", "fit_config", "fresnel_tail",
)  # fmt: skip


def _shexp_attrs(config) -> dict:
    """Root attributes every SH-exp kind shares (FORMAT §5)."""
    return convention_attrs((config.alpha_min, config.alpha_max)) | {
        "technique": "SH exponential (Silvennoinen et al. 2025), K sets linear in alpha (v2)",
        "lmax_p": config.lmax_p,
        "lmax_q": config.lmax_q,
        "sets": config.sets,
        "weights": config.weights,
        "fit_config": config.as_dict(),
        "fresnel_tail": "E1 = E0 * A1/A0 (eq. 15, exact under constant light)",
    }


def _datasets(p, q, knots, dfg, probe_axis: bool):
    axes = ["probe", "set", "coeff", "channel"] if probe_axis else ["set", "coeff", "channel"]
    data = {
        "/p": np.asarray(p, np.float32),
        "/q": np.asarray(q, np.float32),
        "/knots": np.asarray(knots, np.float64),
        "/dfg": dfg.astype(np.float32),
    }
    knots = {"axes": ["set"], "meaning": "GGX width of each coefficient set"}
    dattrs = {"/dfg": DFG_ATTRS, "/p": {"axes": axes}, "/q": {"axes": axes}, "/knots": knots}
    return data, dattrs


def build_shexp_asset(probe, config, dfg: np.ndarray, meta: dict) -> Asset:
    """One probe: ``/p``, ``/q``, ``/knots`` and ``/dfg``."""
    attrs = _shexp_attrs(config) | {"fit_stats": probe.stats, **source_attrs(meta)}
    return Asset("shexp_probe", attrs, *_datasets(probe.p, probe.q, probe.knots, dfg, False))


def build_shexp_set_asset(probes: list[dict], config, dfg: np.ndarray) -> Asset:
    """Many SH-exp probes in one file, one ``/dfg`` and ``/knots``. ``probes``: per probe
    ``{"name", "p", "q", "stats", "meta"}`` in set order."""
    attrs = _shexp_attrs(config) | {
        "probe_count": len(probes),
        "probe_names": [x["name"] for x in probes],
        "probe_sources": [source_attrs(x["meta"]) for x in probes],
        "probe_fit_stats": [x["stats"] for x in probes],
    }
    p = np.stack([x["p"] for x in probes])
    q = np.stack([x["q"] for x in probes])
    return Asset("shexp_probe_set", attrs, *_datasets(p, q, config.knots, dfg, True))


def probe_from_set(asset: Asset, index: int) -> Asset:
    """Probe ``index`` of a ``shexp_probe_set`` as an in-memory ``shexp_probe``."""
    count = int(asset.attrs["probe_count"])
    if not 0 <= index < count:
        raise ParameterError(f"probe index {index} is outside this set of {count} probes")
    sources = asset.attrs["probe_sources"]
    source = (json.loads(sources) if isinstance(sources, str) else sources)[index]
    attrs = {k: asset.attrs[k] for k in SHEXP_ATTRS if k in asset.attrs} | source
    datasets = {"/p": asset["/p"][index], "/q": asset["/q"][index], "/knots": asset["/knots"],
                "/dfg": asset["/dfg"]}  # fmt: skip
    return Asset("shexp_probe", attrs, datasets)
