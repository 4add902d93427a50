"""The ``shexp_probe`` and ``shexp_probe_set`` assets (``docs/FORMAT.md`` §3, kinds
``shexp_probe`` and ``shexp_probe_set``), probe format 2.

``/p`` ``(K, (lmax_p+1)², 3)`` and ``/q`` ``(K, (lmax_q+1)² − 1, 3)`` float32: ``K``
coefficient sets at the GGX widths ``/knots`` ``(K,)`` (float64), blended by
hat functions of ``α`` (:mod:`shbake.shading.shexp`); sets gain a leading
probe axis.
"""

import numpy as np

from shbake.conventions import SHEXP_LMAX_LIMIT
from shbake.errors import FormatError, ParameterError
from shbake.format.asset import Asset
from shbake.format.probe import (
    DFG_ATTRS,
    DFG_DATA,
    PROBE_ATTRS,
    check_alpha_range,
    convention_attrs,
    source_attrs,
)
from shbake.format.registry import (
    AXES_ATTR,
    MAP_KIND_ATTRS,
    MEANING_ATTR,
    PROVENANCE_ATTRS,
    Attr,
    Data,
    Kind,
    register,
)

_SHEXP_ATTRS = PROBE_ATTRS + (
    Attr("lmax_p", "int", "highest band of P", range=(0, SHEXP_LMAX_LIMIT), symbol="lmax_p"),
    Attr("lmax_q", "int", "highest band of Q", range=(1, SHEXP_LMAX_LIMIT), symbol="lmax_q"),
    Attr("sets", "int", "`K`, coefficient sets linear in `α` (hat functions)", range=(1, 64),
         symbol="K"),
    Attr("weights", "str", "the fit's sample weights (`log`, `shaded`, `shaded-nv`, …)"),
    Attr("fit_config", "json", "every fit option, including `targets` and `targets_lmax`; two "
         "probes with equal `fit_config` are comparable", json_type=dict),
    Attr("fresnel_tail", "str", "how `E1` is formed"),
)  # fmt: skip
def _check_knots(values):
    """Knots strictly increasing within ``(0, 1]`` (equal knots would divide by zero in the
    hat weights, :func:`shbake.shading.shexp.hat_weight`)."""
    v = np.asarray(values, dtype=np.float64)
    if np.any(np.diff(v) <= 0) or np.any(v <= 0) or np.any(v > 1):
        raise FormatError("dataset /knots must increase strictly within (0, 1]")


KNOTS_DATA = Data("/knots", ("K",), "float64", "the GGX width of each coefficient set, "
                  "strictly increasing within (0, 1] (hat functions between them)",
                  values=_check_knots, attrs=(AXES_ATTR, MEANING_ATTR))  # fmt: skip


def _check_set(attrs, shapes, dattrs, symbols):
    check_alpha_range(attrs)
    n = attrs["probe_count"]
    for name in ("probe_names", "probe_sources", "probe_fit_stats"):
        if len(attrs[name]) != n:
            raise FormatError(f"attribute {name} must list {n} probes, found {len(attrs[name])}")
    keys = {a.name for a in PROVENANCE_ATTRS if a.required}
    for i, src in enumerate(attrs["probe_sources"]):
        if not isinstance(src, dict) or not keys <= set(src):
            raise FormatError(f"attribute probe_sources[{i}] must hold {', '.join(sorted(keys))}")


SHEXP_PROBE = register(Kind(
    name="shexp_probe",
    version=2,
    title="SH-exponential glossy probe (Silvennoinen et al. 2025; `probe-fit`)",
    attrs=_SHEXP_ATTRS + MAP_KIND_ATTRS + (
        Attr("fit_stats", "json", "`log_rms`, `shaded_relative_rms`, "
             "`shaded_relative_rms_by_alpha` (one per fit α), `floored_targets`, `targets`, "
             "`polish_steps`", json_type=dict),
    ),
    datasets=(
        Data("/p", ("K", "(lmax_p+1)**2", 3), "float32", "SH coefficients of `P` (eq. 11), one "
             "set per knot", attrs=(AXES_ATTR,)),
        Data("/q", ("K", "(lmax_q+1)**2-1", 3), "float32", "SH coefficients of `Q` without the "
             "DC term (eq. 11), one set per knot", attrs=(AXES_ATTR,)),
        KNOTS_DATA,
        DFG_DATA,
    ),
    notes=("A probe asset MUST NOT record times, hosts or command lines: the same map and "
           "configuration give byte-identical files from any runner.",),
    check=lambda attrs, shapes, dattrs, symbols: check_alpha_range(attrs),
))  # fmt: skip

SHEXP_PROBE_SET = register(Kind(
    name="shexp_probe_set",
    version=2,
    title="many SH-exp probes of one configuration, in list order (`probe-fit -o`)",
    attrs=_SHEXP_ATTRS + (
        Attr("probe_count", "int", "`N`", range=(1, 1 << 24), symbol="N"),
        Attr("probe_names", "json", "map stems", json_type=list),
        Attr("probe_sources", "json", "per probe, the provenance block of §2 (and the source "
             "map attributes)", json_type=list),
        Attr("probe_fit_stats", "json", "per probe, `fit_stats` as in `shexp_probe`",
             json_type=list),
    ),
    datasets=(
        Data("/p", ("N", "K", "(lmax_p+1)**2", 3), "float32", "`P` per probe",
             attrs=(AXES_ATTR,)),
        Data("/q", ("N", "K", "(lmax_q+1)**2-1", 3), "float32", "`Q` per probe",
             attrs=(AXES_ATTR,)),
        KNOTS_DATA,
        DFG_DATA,
    ),
    provenance=False,
    notes=("Probe `i` of a set MUST hold the same values as the `shexp_probe` fitted to the "
           "same map with the same configuration.",),
    check=_check_set,
))  # fmt: skip

SHEXP_ATTRS = (
    "technique", "probe_format", "alpha_convention", "alpha_convention_text", "alpha_range",
    "lmax_p", "lmax_q", "sets", "weights", "fit_config", "fresnel_tail",
)  # fmt: skip


def _shexp_attrs(config) -> dict:
    """Root attributes every SH-exp kind shares (FORMAT §3, ``shexp_probe``)."""
    return convention_attrs((config.alpha_min, config.alpha_max)) | {
        "technique": "SH exponential (Silvennoinen et al. 2025), K sets linear in alpha (v2)",
        "lmax_p": config.lmax_p,
        "lmax_q": config.lmax_q,
        "sets": config.sets,
        "weights": config.weights,
        "fit_config": config.as_dict(),
        "fresnel_tail": "E1 = P(rho) Q(rho) * A1(n.v)/A0(1): E0 at n = v = rho, as split-sum "
        "reads its tail (exact under constant light; eq. 15's E0 * A1/A0 before 2026-11-28)",
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
        raise ParameterError(f"--index {index} is outside this set of {count} probes")
    source = asset.attrs["probe_sources"][index]
    attrs = {k: asset.attrs[k] for k in SHEXP_ATTRS if k in asset.attrs} | source
    attrs["fit_stats"] = asset.attrs["probe_fit_stats"][index]
    datasets = {"/p": asset["/p"][index], "/q": asset["/q"][index], "/knots": asset["/knots"],
                "/dfg": asset["/dfg"]}  # fmt: skip
    return Asset("shexp_probe", attrs, datasets)
