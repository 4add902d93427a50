"""What every probe asset shares (``docs/FORMAT.md`` §3, the probe kinds): the DFG table dataset,
the α convention and range, the probe format version, the source record and the
payload size.

Probes record neither a time nor a command line: a probe is a pure function of
its map and its configuration, so the same inputs give byte-identical files
wherever they are baked.

Probe format 2 (this version) parameterises everything by the GGX width ``α``
(SPEC §1; the attribute ``alpha_convention``). Format-1 probes took perceptual
roughness ``r`` (``α = r²``) *and* used ``vMF(1/r)`` in the fit, a model that
cannot be re-read in ``α`` terms; they are refused (:func:`check_probe_asset`)
with a one-line message asking for a re-bake.
"""

import json

import numpy as np

from shbake.conventions import DFG_MU_MIN, DFG_SAMPLES, DFG_SIZE, ROUGHNESS_MIN
from shbake.errors import FormatError, ParameterError
from shbake.format.asset import Asset
from shbake.format.provenance import map_source
from shbake.format.registry import AXES_ATTR, MEANING_ATTR, Attr, Data

PROBE_FORMAT = 2
"""Version of the probe kinds' layout and parameterisation."""
ALPHA_CONVENTION = "ggx_width"
ALPHA_CONVENTION_TEXT = (
    "alpha is the GGX width (Walter et al. 2007, Mitsuba alpha); perceptual roughness r "
    "maps as alpha = r^2 (Burley 2012)"
)
DFG_ATTRS = {
    "axes": ["n_dot_v", "sqrt_alpha", "A0_A1"],
    "n_dot_v_range": [DFG_MU_MIN, 1.0],
    "sqrt_alpha_range": [ROUGHNESS_MIN, 1.0],
    "samples": DFG_SAMPLES,
    "meaning": "A0 = int f_DV (n.l) dl, A1 = int f_DV (1-v.h)^5 (n.l) dl; node-centred in "
    "(n.v, sqrt(alpha)), bilinear",
}


def convention_attrs(alpha_range) -> dict:
    """The attributes that say how a probe reads ``α`` (every probe kind)."""
    lo, hi = (float(x) for x in alpha_range)
    return {
        "probe_format": PROBE_FORMAT,
        "alpha_convention": ALPHA_CONVENTION,
        "alpha_convention_text": ALPHA_CONVENTION_TEXT,
        "alpha_range": [lo, hi],
    }


def _attr(asset: Asset, name: str):
    v = asset.attrs.get(name)
    return json.loads(v) if isinstance(v, str) and v[:1] in "[{" else v


def check_probe_asset(asset: Asset, path: str = "probe") -> Asset:
    """Refuse probes of another ``α`` convention or a newer probe format (one line)."""
    if asset.attrs.get("alpha_convention") != ALPHA_CONVENTION:
        raise FormatError(
            f"{path}: this {asset.kind} was baked with perceptual roughness (probe format 1); "
            "shbake now reads alpha as the GGX width: re-bake it with this version"
        )
    version = asset.attrs.get("probe_format")
    if not isinstance(version, int | np.integer) or not 2 <= int(version) <= PROBE_FORMAT:
        raise FormatError(
            f"{path}: probe format {version!r} is not supported (reads 2…{PROBE_FORMAT})"
        )
    return asset


def source_attrs(meta: dict) -> dict:
    """The provenance block of a probe from an environment's ``meta`` (FORMAT §2)."""
    return map_source(meta)


ALPHA_MIN = ROUGHNESS_MIN * ROUGHNESS_MIN
"""Smallest GGX width a probe may be fitted or shaded at."""


def _check_range(value):
    lo, hi = value
    if not (isinstance(lo, int | float) and isinstance(hi, int | float)
            and ALPHA_MIN - 1e-12 <= lo <= hi <= 1.0 + 1e-9):  # fmt: skip
        raise FormatError(f"attribute alpha_range {value!r:.60} must be [lo, hi] with "
                          f"{ALPHA_MIN:g} ≤ lo ≤ hi ≤ 1")  # fmt: skip


DFG_DATA = Data(
    "/dfg", (DFG_SIZE, DFG_SIZE, 2), "float32",
    "`A0`, `A1` over node-centred `n·v ∈ [1e-3, 1]` × `sqrt(α) ∈ [0.02, 1]` (attributes say "
    "so); bilinear, clamped",
    attrs=(AXES_ATTR,
           Attr("n_dot_v_range", "json", "`[lo, hi]` of the n·v axis", json_type=list, length=2,
                required=False),
           Attr("sqrt_alpha_range", "json", "`[lo, hi]` of the sqrt(α) axis", json_type=list,
                length=2, required=False),
           Attr("samples", "int", "quadrature samples per entry", range=(1, 1 << 31),
                required=False),
           MEANING_ATTR),
)  # fmt: skip
"""The DFG table every probe kind carries."""

PROBE_ATTRS = (
    Attr("technique", "str", "the technique and its paper"),
    Attr("probe_format", "int", "version of the probe layout and parameterisation; readers "
         f"MUST refuse other values than {PROBE_FORMAT}", range=(PROBE_FORMAT, PROBE_FORMAT)),
    Attr("alpha_convention", "str", f"`{ALPHA_CONVENTION}`: `α` is the GGX width (SPEC §1); "
         "readers MUST refuse others (probe format 1 used perceptual roughness)"),
    Attr("alpha_convention_text", "str", "the convention in words"),
    Attr("alpha_range", "json", "`[lo, hi]` GGX widths fitted; readers MUST refuse `α` outside "
         "it unless they document extrapolation (shbake's refuse it)", json_type=list, length=2),
)  # fmt: skip
"""Root attributes every probe kind shares."""


def check_alpha_range(attrs: dict) -> None:
    """The kind check shared by probes: a sane ``alpha_range`` and the GGX-width convention."""
    if attrs.get("alpha_convention") != ALPHA_CONVENTION:
        raise FormatError(
            "this probe was baked with perceptual roughness (probe format 1); shbake now reads "
            "alpha as the GGX width: re-bake it with this version"
        )
    _check_range(attrs["alpha_range"])


def probe_bytes(asset: Asset, bytes_per_value: int = 4) -> int:
    """Bytes of the per-probe payload (the shared ``/dfg`` table and level/knot axes
    excluded)."""
    return bytes_per_value * sum(
        int(np.prod(a.shape))
        for name, a in asset.datasets.items()
        if name not in ("/dfg", "/level_alpha", "/knots")
    )


def check_probe_alpha(asset: Asset, alpha) -> float:
    """Refuse a shading GGX width outside the probe's ``alpha_range``.

    Neither probe extrapolates: SH-exp was fitted on that range only and the
    split-sum chain has no level outside it.
    """
    check_probe_asset(asset)
    lo, hi = (float(x) for x in _attr(asset, "alpha_range"))
    a = float(alpha)
    if not (np.isfinite(a) and lo - 1e-9 <= a <= hi + 1e-9):
        raise ParameterError(
            f"alpha {a:g} is outside this probe's range [{lo:g}, {hi:g}] (GGX width); "
            "probes do not extrapolate (refit with another alpha range)"
        )
    return a
