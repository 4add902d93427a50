"""The ``shexp_probe``, ``shexp_probe_set`` and ``splitsum_probe`` assets (``docs/FORMAT.md`` §5–7).

Both carry the shared DFG table ``/dfg`` (``A0``, ``A1`` over ``(n·v, r)``)
so the preview needs nothing else. Neither records a time or a command line:
a probe is a pure function of its map and its configuration, so the same
inputs give byte-identical files wherever they are baked.
"""

import json

import numpy as np

from shbake.errors import ParameterError
from shbake.format.asset import Asset
from shbake.probe.albedo_table import MU_MIN, TABLE_SAMPLES
from shbake.probe.ggx_integrals import ROUGHNESS_MIN
from shbake.probe.shexp import FitConfig, ShexpProbe
from shbake.probe.splitsum import SplitSumConfig

ROUGHNESS_CONVENTION = "perceptual roughness r; GGX width alpha = r^2 (Burley 2012)"
DFG_ATTRS = {
    "axes": ["n_dot_v", "roughness", "A0_A1"],
    "n_dot_v_range": [MU_MIN, 1.0],
    "roughness_range": [ROUGHNESS_MIN, 1.0],
    "samples": TABLE_SAMPLES,
    "meaning": "A0 = int f_DV (n.l) dl, A1 = int f_DV (1-v.h)^5 (n.l) dl; node-centred, bilinear",
}


def _source_attrs(meta: dict) -> dict:
    keep = ("sha256", "width", "height", "layout", "colorspace", "negative_policy")
    return {f"source_{k}": meta[k] for k in keep if k in meta} | {
        "source_name": str(meta.get("path", "")).rsplit("/", 1)[-1]
    }


def _shexp_attrs(config: FitConfig) -> dict:
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


def build_shexp_asset(probe: ShexpProbe, config: FitConfig, dfg: np.ndarray, meta: dict) -> Asset:
    """``/p`` ``(n_p, 3)``, ``/q`` ``(n_q − 1, 3)`` float32 and ``/dfg``."""
    attrs = _shexp_attrs(config) | {"fit_stats": probe.stats, **_source_attrs(meta)}
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


def build_shexp_set_asset(probes: list[dict], config: FitConfig, dfg: np.ndarray) -> Asset:
    """Many SH-exp probes in one file: ``/p`` ``(N, n_p, 3)``, ``/q`` ``(N, n_q − 1, 3)``,
    one ``/dfg``. ``probes``: per probe ``{"name", "p", "q", "stats", "meta"}`` in set order."""
    attrs = _shexp_attrs(config) | {
        "probe_count": len(probes),
        "probe_names": [x["name"] for x in probes],
        "probe_sources": [_source_attrs(x["meta"]) for x in probes],
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
    shared = _shexp_attrs(FitConfig())  # the names only
    attrs = {k: asset.attrs[k] for k in shared} | source
    datasets = {"/p": asset["/p"][index], "/q": asset["/q"][index], "/dfg": asset["/dfg"]}
    return Asset("shexp_probe", attrs, datasets)


def build_splitsum_asset(levels, config: SplitSumConfig, dfg: np.ndarray, meta: dict) -> Asset:
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
        **_source_attrs(meta),
    }
    return Asset("splitsum_probe", attrs, datasets, {"/dfg": DFG_ATTRS})


def probe_bytes(asset: Asset, bytes_per_value: int = 4) -> int:
    """Bytes of the per-probe payload (the shared ``/dfg`` table excluded)."""
    return bytes_per_value * sum(
        int(np.prod(a.shape))
        for name, a in asset.datasets.items()
        if name not in ("/dfg", "/level_roughness")
    )


def check_probe_roughness(asset: Asset, roughness) -> float:
    """Refuse a shading roughness outside the probe's ``roughness_range``.

    Neither probe extrapolates: SH-exp was fitted on that range only and the
    split-sum chain has no level outside it.
    """
    span = asset.attrs["roughness_range"]  # a list in memory, JSON text once read back
    lo, hi = (float(x) for x in (json.loads(span) if isinstance(span, str) else span))
    r = float(roughness)
    if not (np.isfinite(r) and lo - 1e-9 <= r <= hi + 1e-9):
        raise ParameterError(
            f"roughness {r:g} is outside this probe's fitted range [{lo:g}, {hi:g}]; "
            "probes do not extrapolate (refit with --roughness-range)"
        )
    return r
