"""The ``env_sh`` asset kind: SH lighting, Lambert and Kajiya–Kay irradiance, optional lights.

Version 3 (issue 33) added ``/lights/*``: directional lights fitted to the irradiance
(:mod:`shbake.bakers.env_lights`); a version-2 reader would have ignored them and shaded
without their energy, hence the new version. Version 4 added ``/lights/angular_radius``
(sphere lights, ``project-env --light-shape sphere``): a version-3 reader would shade them
as points.

Built by :func:`shbake.bakers.env_sh.bake_env_sh`, shaded by :mod:`shbake.shading.env_sh`.
"""

import numpy as np

from shbake.conventions import LMAX_LIMIT, REC709_LUMINANCE
from shbake.errors import FormatError
from shbake.format.registry import (
    MAP_POLICY_ATTRS,
    SOURCE_MAP_ATTRS,
    Attr,
    Data,
    Kind,
    register,
)

RADIUS_LIMIT = np.pi / 3.0
"""Largest angular radius ``/lights/angular_radius`` holds (60°; the fit's is 30°)."""
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
    if "/lights/irradiance" in shapes and "/lights/direction" not in shapes:
        raise FormatError("missing dataset /lights/direction (required with /lights/irradiance)")
    if "/lights/direction" in shapes and "/sun/direction" in shapes:
        raise FormatError("an env_sh asset holds /sun or /lights, not both")
    if "/lights/angular_radius" in shapes and "/lights/direction" not in shapes:
        raise FormatError("missing dataset /lights/direction (required with "
                          "/lights/angular_radius)")  # fmt: skip


def check_sun(direction: np.ndarray) -> None:
    """Refuse a sun direction that is not a unit vector (values are checked after loading)."""
    n = float(np.linalg.norm(direction))
    if abs(n - 1.0) > SUN_NORM_TOLERANCE:
        raise FormatError(f"dataset /sun/direction is not a unit vector (length {n:.6g})")


def check_light_directions(directions: np.ndarray) -> None:
    """Refuse light directions that are not unit vectors."""
    n = np.linalg.norm(np.asarray(directions, dtype=np.float64).reshape(-1, 3), axis=1)
    bad = np.flatnonzero(np.abs(n - 1.0) > SUN_NORM_TOLERANCE)
    if bad.size:
        raise FormatError(f"dataset /lights/direction row {int(bad[0])} is not a unit vector "
                          f"(length {n[bad[0]]:.6g})")  # fmt: skip


def check_light_radii(radii: np.ndarray) -> None:
    """Refuse sphere-light radii outside ``[0, π/3]``: the fit stops at 30°; a cap near half
    the sky is no light, and at ``σ → π/2`` a float32 shader's ``cos σ`` is round-off (the
    WebGL pass drew 0 for 0.25 at 1.5707963)."""
    r = np.asarray(radii, dtype=np.float64)
    if np.any((r < 0.0) | (r > RADIUS_LIMIT)):
        raise FormatError("dataset /lights/angular_radius has values outside [0, π/3]")


def check_light_irradiance(irradiance: np.ndarray) -> None:
    """Refuse negative light irradiance (a light cannot take energy away)."""
    if np.any(np.asarray(irradiance) < 0.0):
        raise FormatError("dataset /lights/irradiance has negative values")


_LMAX = Attr("lmax", "int", "highest band", range=(0, LMAX_LIMIT), symbol="lmax")
_LMAX_IRR = Attr("lmax", "int", "highest band", range=(0, LMAX_LIMIT), symbol="lmax_irr")
_KERNEL = Attr("kernel", "str", "the kernel `L` was convolved with", required=False)

ENV_SH = register(Kind(
    name="env_sh",
    version=4,
    reads=(2, 3),  # 3 added the optional /lights, 4 their /lights/angular_radius
    title="SH lighting and irradiance of an environment map (`project-env`)",
    attrs=SOURCE_MAP_ATTRS + MAP_POLICY_ATTRS,
    datasets=(
        Data("/lighting/sh", ("(lmax+1)**2", 3), "float64",
             "`L_lm = ∫ L y_lm dω`, raw projection (of the residual if a sun was extracted); "
             "with `/lights`, the residual's SH: bands the Lambert kernel sees up to the "
             "irradiance lmax fitted (`E_i / Â_l`), the others projected from the map less "
             "the lights as directional (delta) lights, sphere lights as their caps' SH",
             attrs=(_LMAX, Attr("sun_removed", "bool", "a sun was extracted first"),
                    Attr("quadrature", "str", "how the integral was computed", required=False),
                    Attr("lights_fitted", "bool", "`/lights` were fitted with this residual",
                         required=False))),
        Data("/lighting/band_energy", ("lmax+1", 3), "float64", "`Σ_m L_lm²` per band"),
        Data("/lighting/window", ("lmax_irr+1",), "float64",
             "band window applied before the kernels",
             attrs=(Attr("method", "str", "`none`, `hann`, `lanczos` or `dering`"), _LMAX_IRR,
                    Attr("reconstruction_minimum", "float", "for `dering`: the smallest "
                         "reconstructed value", required=False))),
        Data("/irradiance/sh", ("(lmax_irr+1)**2", 3), "float64",
             "`E_i = Â_l w_l L_i`: `E(n) = Σ_i y_i(n) E_i`", required=False,
             attrs=(_LMAX_IRR, _KERNEL)),
        Data("/tangent_irradiance/sh", ("(lmax_irr+1)**2", 3), "float64",
             "`A_l w_l L_i` (Kajiya–Kay): `E(t) = Σ_i y_i(t) E_i`", required=False,
             attrs=(_LMAX_IRR, _KERNEL)),
        Data("/tangent_irradiance/matrix", (3, 4, 4), "float64",
             "per channel `M` of Mehta eq. 24: `E(t) = [t,1]ᵀ M [t,1]`; MUST with "
             "`/tangent_irradiance/sh` when its lmax ≥ 2", required=False,
             attrs=(Attr("form", "str", "how `M` is read", required=False),)),
        Data("/sun/direction", (3,), "float64", "unit vector toward the light, world frame",
             required=False, values=check_sun,
             attrs=(Attr("frame", "str", "the vector's frame and sense", required=False),)),
        Data("/sun/solid_angle", (), "float64", "sr", required=False, with_="/sun/direction"),
        Data("/sun/radiance", (3,), "float64",
             "RGB radiance; `radiance × solid_angle` is its irradiance at normal incidence",
             required=False, with_="/sun/direction",
             attrs=(Attr("units", "str", "what the values measure", required=False),)),
        Data("/lights/direction", ("K", 3), "float64", "unit vectors toward the lights, world "
             "frame, brightest (luminance) first", required=False, values=check_light_directions,
             attrs=(Attr("requested", "str", "`auto` or the number of lights asked for"),
                    Attr("tolerance", "float", "`auto`: the mean relative error aimed at",
                         required=False, range=(0.0, 1.0)),
                    Attr("fit_directions", "int", "spherical-Fibonacci normals the fit was "
                         "measured at", range=(1, 1 << 30)),
                    Attr("fit_mean_error", "float", "mean relative luminance error of SH + "
                         "lights against brute force at those normals", range=(0.0, 1e300)),
                    Attr("fit_max_error", "float", "the largest", range=(0.0, 1e300)))),
        Data("/lights/irradiance", ("K", 3), "float64", "RGB irradiance at normal incidence "
             "(radiance × sr), ≥ 0", required=False, with_="/lights/direction",
             values=check_light_irradiance),
        Data("/lights/angular_radius", ("K",), "float64", "angular radius σ of each light, "
             "radians in [0, π/3]: a sphere light (uniform cap); absent: every light a point",
             required=False, values=check_light_radii),
    ),
    notes=(
        "When `/sun/*` is present, consumers MUST add the light to the SH irradiance: "
        "`E(n) += radiance·solid_angle·max(0, n·s)` and "
        "`E_t(t) += radiance·solid_angle·sqrt(1 − (t·s)²)/π²`.",
        "`/sun/direction` MUST be a unit vector (to 1e-3).",
        "When `/lights/*` is present (`project-env --lights`), consumers MUST add every "
        "light `k`: `E(n) += irradiance_k·max(0, n·d_k)` and "
        "`E_t(t) += irradiance_k·sqrt(1 − (t·d_k)²)/π²`; the lights and the SH were fitted "
        "together by least squares on the irradiance, so neither is meaningful alone, but "
        "the SH irradiance is non-negative by itself (a shadowed light leaves a valid SH) "
        "and `∫ E dn` of SH + lights is `π ∫ L dω` of the map (energy conserved).",
        "When `/lights/angular_radius` is present, consumers MUST shade light `k` as a "
        "sphere of radius `σ_k`: `E(n) += irradiance_k·K(n·d_k, σ_k)`, `K` the horizon-clipped "
        "irradiance of a uniform cap per unit irradiance at normal incidence (Snyder 1996), "
        "and `E_t(t) += irradiance_k·J(t·d_k, σ_k)/π²`, `J` the cap's mean of "
        "`sqrt(1 − (t·ω)²)` times its energy factor (docs/CONVENTIONS.md); an exporter whose "
        "target shades lights as points MUST refuse the asset when a radius is not 0. The "
        "light's energy is "
        "`2·irradiance_k/(1 + cos σ_k)`.",
        "An asset holds `/sun` or `/lights`, never both; every `/lights/direction` row "
        "MUST be a unit vector (to 1e-3) and `/lights/irradiance` MUST be ≥ 0.",
    ),
    check=_check,
))  # fmt: skip


def asset_lights(asset) -> list[dict]:
    """The directional lights of an ``env_sh`` asset as people read them: the extracted sun
    (``/sun``: irradiance at normal incidence = radiance × solid angle) or the fitted lights
    (``/lights``), each with its world ``direction`` (unit, toward the light),
    ``elevation_deg`` above the horizon (+Y up) and ``azimuth_deg`` (the lat-long map's
    ``u × 360°``: 0 at −Z, 90 at +X, SPEC §3), ``irradiance`` (R, G, B), ``intensity`` (its
    Rec.709 luminance) and ``colour`` (``irradiance / intensity``: luminance 1); sphere
    lights also their ``angular_radius_deg``. Empty when the asset has neither."""
    if "/sun/direction" in asset:
        sun_irradiance = np.asarray(asset["/sun/radiance"]) * float(asset["/sun/solid_angle"])
        found = [("sun", asset["/sun/direction"], sun_irradiance)]
    elif "/lights/direction" in asset:
        pairs = zip(asset["/lights/direction"], asset["/lights/irradiance"], strict=True)
        found = [(f"light {k}", d, e) for k, (d, e) in enumerate(pairs)]
    else:
        return []
    radii = (np.degrees(np.asarray(asset["/lights/angular_radius"], dtype=np.float64)).ravel()
             if "/lights/angular_radius" in asset else None)  # fmt: skip
    out = []
    for k, (name, direction, irradiance) in enumerate(found):
        d = np.asarray(direction, dtype=np.float64).reshape(3)
        e = np.asarray(irradiance, dtype=np.float64).reshape(-1)
        intensity = float(e @ REC709_LUMINANCE) if e.size == 3 else float(e.mean())
        out.append({
            "name": name, "direction": d.tolist(),
            "elevation_deg": float(np.degrees(np.arcsin(np.clip(d[1], -1.0, 1.0)))),
            "azimuth_deg": float(np.degrees(np.arctan2(d[0], -d[2])) % 360.0),
            "irradiance": e.tolist(), "intensity": intensity,
            "colour": (e / intensity).tolist() if intensity > 0 else e.tolist(),
        })  # fmt: skip
        if radii is not None:
            out[-1]["angular_radius_deg"] = float(radii[k])
    return out
