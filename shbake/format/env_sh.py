"""The ``env_sh`` asset kind: SH lighting, Lambert and Kajiya–Kay irradiance, an optional sun.

Built by :func:`shbake.bakers.env_sh.bake_env_sh`, shaded by :mod:`shbake.shading.env_sh`.
"""

import numpy as np

from shbake.conventions import LMAX_LIMIT
from shbake.errors import FormatError
from shbake.format.registry import SOURCE_MAP_ATTRS, Attr, Data, Kind, register

SUN_NORM_TOLERANCE = 1e-3
"""``| |s| − 1 |`` above this refuses ``/sun/direction``."""


def _check(attrs, shapes, dattrs, symbols):
    lmax, lmax_irr = symbols.get("lmax"), symbols.get("lmax_irr")
    if lmax_irr is not None and lmax is not None and lmax_irr > lmax:
        raise FormatError(f"irradiance lmax {lmax_irr} exceeds the lighting lmax {lmax}")
    if (
        "/tangent_irradiance/sh" in shapes
        and lmax_irr >= 2
        and ("/tangent_irradiance/matrix" not in shapes)
    ):
        raise FormatError("missing dataset /tangent_irradiance/matrix (required with "
                          "/tangent_irradiance/sh of lmax >= 2)")  # fmt: skip
    sun = [n for n in ("/sun/solid_angle", "/sun/radiance") if n in shapes]
    if sun and "/sun/direction" not in shapes:  # the light would be dropped silently
        raise FormatError(f"missing dataset /sun/direction (required with {sun[0]})")


def check_sun(direction: np.ndarray) -> None:
    """Refuse a sun direction that is not a unit vector (values are checked after loading)."""
    n = float(np.linalg.norm(direction))
    if abs(n - 1.0) > SUN_NORM_TOLERANCE:
        raise FormatError(f"dataset /sun/direction is not a unit vector (length {n:.6g})")


_LMAX = Attr("lmax", "int", "highest band", range=(0, LMAX_LIMIT), symbol="lmax")
_LMAX_IRR = Attr("lmax", "int", "highest band", range=(0, LMAX_LIMIT), symbol="lmax_irr")

ENV_SH = register(Kind(
    name="env_sh",
    version=2,
    title="SH lighting and irradiance of an environment map (`project-env`)",
    attrs=SOURCE_MAP_ATTRS + (
        Attr("source_stored_format", "str", "pixel type stored in the input file"),
        Attr("source_channels", "str", "how the input's channels became RGB"),
        Attr("source_nonfinite_repaired", "int", "pixels repaired by the non-finite policy",
             range=(0, 1 << 62)),
        Attr("source_negative_count", "int", "negative pixels found", range=(0, 1 << 62)),
        Attr("source_negative_energy_change", "floats", "change of `∫L dω` per channel by the "
             "negative policy", length=3),
    ),
    datasets=(
        Data("/lighting/sh", ("(lmax+1)**2", 3), "float64",
             "`L_lm = ∫ L y_lm dω`, raw projection (of the residual if a sun was extracted)",
             attrs=(_LMAX, Attr("sun_removed", "bool", "a sun was extracted first"),
                    Attr("quadrature", "str", "how the integral was computed", required=False))),
        Data("/lighting/band_energy", ("lmax+1", 3), "float64", "`Σ_m L_lm²` per band"),
        Data("/lighting/window", ("lmax_irr+1",), "float64",
             "band window applied before the kernels",
             attrs=(Attr("method", "str", "`none`, `hann`, `lanczos` or `dering`"), _LMAX_IRR,
                    Attr("reconstruction_minimum", "float", "for `dering`: the smallest "
                         "reconstructed value", required=False))),
        Data("/irradiance/sh", ("(lmax_irr+1)**2", 3), "float64",
             "`E_i = Â_l w_l L_i`: `E(n) = Σ_i y_i(n) E_i`", required=False,
             attrs=(_LMAX_IRR,)),
        Data("/tangent_irradiance/sh", ("(lmax_irr+1)**2", 3), "float64",
             "`A_l w_l L_i` (Kajiya–Kay): `E(t) = Σ_i y_i(t) E_i`", required=False,
             attrs=(_LMAX_IRR,)),
        Data("/tangent_irradiance/matrix", (3, 4, 4), "float64",
             "per channel `M` of Mehta eq. 24: `E(t) = [t,1]ᵀ M [t,1]`; MUST with "
             "`/tangent_irradiance/sh` when its lmax ≥ 2", required=False),
        Data("/sun/direction", (3,), "float64", "unit vector toward the light, world frame",
             required=False, values=check_sun),
        Data("/sun/solid_angle", (), "float64", "sr", required=False, with_="/sun/direction"),
        Data("/sun/radiance", (3,), "float64",
             "RGB radiance; `radiance × solid_angle` is its irradiance at normal incidence",
             required=False, with_="/sun/direction"),
    ),
    notes=(
        "When `/sun/*` is present, consumers MUST add the light to the SH irradiance: "
        "`E(n) += radiance·solid_angle·max(0, n·s)` and "
        "`E_t(t) += radiance·solid_angle·sqrt(1 − (t·s)²)/π²`.",
        "`/sun/direction` MUST be a unit vector (to 1e-3).",
    ),
    check=_check,
))  # fmt: skip
