"""The ``env_sh`` baker: SH lighting, Lambert and Kajiya–Kay irradiance of an environment.

``bake_env_sh`` turns an :class:`~shbake.envmap.Environment` into an
``env_sh`` :class:`~shbake.format.asset.Asset` (``docs/FORMAT.md`` §3);
``truncation_report`` says what the chosen ``lmax`` loses (RH02 §5.1).
Shaded by :mod:`shbake.shading.env_sh`, measured by :mod:`shbake.evaluation.env_sh`.
"""

import base64
import time
from typing import NamedTuple

import numpy as np

from shbake.bakers.env_lights import (
    AUTO_MAX_LIGHTS,
    FIT_DIRECTIONS,
    MAX_LIGHTS,
    SHAPES,
    choose_lights,
    irradiance_target,
    light_chain,
)
from shbake.conventions import band_of_index, check_lmax, lmax_of
from shbake.envmap.environment import Environment
from shbake.envmap.sun import SUN_RADIUS_DEG, Sun, extract_sun
from shbake.errors import ParameterError
from shbake.format.asset import Asset
from shbake.format.provenance import map_source
from shbake.sh.kernels import kajiya_kay_kernel, lambert_kernel
from shbake.sh.rotation import rotate
from shbake.sh.tangent_irradiance import matrix_form
from shbake.sh.windows import WINDOW_METHODS, dering_window, window
from shbake.shading.sphere_light import lights_sh, sphere_power

REPORT_LMAX = 64
"""Band up to which ``--report`` projects to estimate what truncation loses."""


class Projection(NamedTuple):
    """What :func:`bake_env_sh` reads from a map's pixels (without fitted lights): the
    lighting SH ``sh`` (``((lmax+1)², 3)``, the map's frame) of the map less its sun, and
    when a sun was asked for (``sun_radius_deg``) the extracted ``light`` (or ``None``) and
    the extraction's ``sun_report`` (:func:`shbake.envmap.sun.extract_sun`)."""

    sh: np.ndarray
    sun_radius_deg: float | None
    light: Sun | None
    sun_report: dict | None

    def to_record(self) -> dict:
        """The projection as JSON values, every float64 kept exactly (``sh`` as
        little-endian bytes in base64, other floats by ``repr``): what a scene's plan keeps
        for the bake (:meth:`from_record`)."""
        light = None if self.light is None else {
            "direction": self.light.direction.tolist(), "solid_angle": self.light.solid_angle,
            "radiance": self.light.radiance.tolist()}  # fmt: skip
        return {"sh": base64.b64encode(np.asarray(self.sh, "<f8").tobytes()).decode(),
                "sun_radius_deg": self.sun_radius_deg, "light": light,
                "sun_report": self.sun_report}  # fmt: skip

    @classmethod
    def from_record(cls, record, lmax: int, sun_radius_deg: float | None) -> "Projection | None":
        """The projection :meth:`to_record` wrote for ``lmax`` and ``sun_radius_deg``;
        ``None`` when ``record`` is not one (it comes from a lock or cache file: untrusted) —
        another ``lmax`` or sun radius, wrong shapes or types, non-finite values."""
        if not isinstance(record, dict) or record.keys() != PROJECTION_KEYS:
            return None
        if record["sun_radius_deg"] != sun_radius_deg:
            return None
        try:
            raw = base64.b64decode(record["sh"], validate=True)
        except (TypeError, ValueError):
            return None
        if len(raw) != 8 * 3 * (lmax + 1) ** 2:
            return None
        sh = np.frombuffer(raw, "<f8").astype(np.float64).reshape((lmax + 1) ** 2, 3)
        light, report = record["light"], record["sun_report"]
        if sun_radius_deg is None:
            ok = light is None and report is None
        else:
            ok = _is_sun_report(report) and (
                (light is None and report["extracted"] is False)
                or (report["extracted"] is True and _is_light(light)))  # fmt: skip
        if not (ok and np.all(np.isfinite(sh))):
            return None
        if light is not None:
            light = Sun(np.array(light["direction"], np.float64), light["solid_angle"],
                        np.array(light["radiance"], np.float64))  # fmt: skip
        return cls(sh, sun_radius_deg, light, report)


PROJECTION_KEYS = {"sh", "sun_radius_deg", "light", "sun_report"}
"""The keys of :meth:`Projection.to_record`."""


def _floats(value, n: int) -> bool:
    return (isinstance(value, list) and len(value) == n
            and all(type(x) is float and np.isfinite(x) for x in value))  # fmt: skip


def _is_light(light) -> bool:
    """Whether ``light`` is a :meth:`Projection.to_record` sun: a unit direction, a positive
    solid angle, a finite RGB radiance."""
    return (isinstance(light, dict) and light.keys() == {"direction", "solid_angle", "radiance"}
            and _floats(light["direction"], 3)
            and abs(float(np.linalg.norm(light["direction"])) - 1.0) < 1e-9
            and _floats([light["solid_angle"]], 1) and light["solid_angle"] > 0.0
            and _floats(light["radiance"], 3))  # fmt: skip


def _is_sun_report(report) -> bool:
    """Whether ``report`` has the keys and JSON types :func:`extract_sun`'s report takes."""
    if not isinstance(report, dict) or type(report.get("extracted")) is not bool:
        return False
    keys = SUN_REPORT_KEYS | (SUN_EXTRACTED_KEYS if report["extracted"] else set())
    return (report.keys() == keys and _floats([report["peak_luminance"]], 1)
            and _floats(report["background"], 3) and _floats([report["contrast"]], 1)
            and (not report["extracted"] or (_floats(report["energy_fraction"], 3)
                                             and type(report["texels"]) is int)))  # fmt: skip


SUN_REPORT_KEYS = {"peak_luminance", "background", "contrast", "extracted"}
SUN_EXTRACTED_KEYS = {"energy_fraction", "texels"}
"""The keys of :func:`extract_sun`'s report (JSON form), and those it adds for a light."""


def project_lighting(env: Environment, lmax: int, sun_radius_deg: float | None = None,
                     extracted: tuple | None = None) -> Projection:  # fmt: skip
    """The :class:`Projection` of ``env`` to ``lmax``: its sun extracted first when
    ``sun_radius_deg`` is given (``extracted``: :func:`extract_sun`'s result for that
    radius, made earlier). Its values are those :func:`bake_env_sh` writes."""
    if sun_radius_deg is None:
        return Projection(env.project(lmax), None, None, None)
    light, residual, report = extracted or extract_sun(env, radius_deg=sun_radius_deg)
    return Projection(residual.project(lmax), sun_radius_deg, light, _jsonable(report))


def band_energy(coeffs) -> np.ndarray:
    """``Σ_m L_lm²`` per band and channel, shape ``(lmax+1, C)`` (RH02 §5.1)."""
    c = np.asarray(coeffs, dtype=np.float64)
    lmax = lmax_of(c.shape[0])
    return np.stack([np.sum(c[l * l : (l + 1) ** 2] ** 2, axis=0) for l in range(lmax + 1)])


def bake_env_sh(
    env: Environment,
    lmax: int = 2,
    window_name: str = "none",
    irradiance_lmax: int = 2,
    irradiance: bool = True,
    tangent: bool = True,
    sun: bool = False,
    sun_radius_deg: float = SUN_RADIUS_DEG,
    provenance: dict | None = None,
    rotation: np.ndarray | None = None,
    lights: int | str | None = None,
    light_tol: float = 0.01,
    light_shape: str = "point",
    projection: Projection | None = None,
) -> tuple[Asset, dict]:
    """Bake an ``env_sh`` asset.

    Parameters
    ----------
    lmax : int, 0 … 128
        Highest band of ``/lighting/sh``.
    window_name : one of ``none, hann, lanczos, dering``
        Window applied to the lighting before the irradiance kernels.
    irradiance_lmax : int, 0 … lmax
        Highest band of ``/irradiance/sh`` and ``/tangent_irradiance/sh``
        (``Â_l`` / ``A_l`` folded in, so ``E(n) = Σ_i y_i(n) E_i``).
    sun : bool
        Extract the dominant compact light (:mod:`shbake.envmap.sun`) and
        project the residual.
    rotation : (3, 3) array, optional
        Turn the environment by ``R`` (a scene probe's pose, :mod:`shbake.envmap.turn`):
        the SH become ``M(R) L`` (:func:`shbake.sh.rotation.rotate`, exact) and the sun's
        direction ``R d``; everything derived from them follows.
    lights : ``"auto"``, int 0 … 8, or None
        Fit directional lights and the residual's irradiance SH together by least squares
        on the irradiance (:mod:`shbake.bakers.env_lights`): that many lights, or with
        ``"auto"`` the fewest (up to 3) whose mean relative error meets ``light_tol``.
        Not with ``sun`` nor a window (the fit is the irradiance).
    light_shape : one of ``point, sphere``
        ``sphere``: each light a uniform cap of fitted angular radius (``/lights/angular_radius``),
        shaded by its horizon-clipped irradiance and its cap-averaged Kajiya–Kay term
        (:mod:`shbake.shading.sphere_light`).
    projection : Projection, optional
        :func:`project_lighting` of this ``env`` at ``lmax`` (and ``sun_radius_deg`` with
        ``sun``), made earlier (a scene's plan): used instead of projecting again. Not with
        ``lights``.

    Returns
    -------
    (asset, summary)
    """
    lmax = check_lmax(lmax)
    irradiance_lmax = check_lmax(irradiance_lmax, "irradiance lmax")
    if irradiance_lmax > lmax:
        raise ParameterError(f"irradiance lmax {irradiance_lmax} exceeds lmax {lmax}")
    if window_name not in WINDOW_METHODS:
        raise ParameterError(
            f"unknown window {window_name!r}; choose one of {', '.join(WINDOW_METHODS)}"
        )
    t0 = time.perf_counter()
    summary: dict = {"lmax": lmax, "irradiance_lmax": irradiance_lmax, "window": window_name}
    datasets: dict = {}
    dattrs: dict = {}
    light = None
    fit = None
    check_lights(lights, light_tol, sun, window_name, light_shape)
    radius = sun_radius_deg if sun else None  # what a projection of these settings holds
    if projection is not None and (
            lights is not None or projection.sh.shape[0] != (lmax + 1) ** 2
            or projection.sun_radius_deg != radius):  # fmt: skip
        raise ParameterError("the projection given is not one of these settings")
    if lights is not None:
        fit, summary["lights"] = _fit(env, lights, light_tol, irradiance_lmax, light_shape)
    if fit is not None and fit.count:  # no light found: the SH alone (fitted), no /lights
        directions = fit.directions if rotation is None else fit.directions @ np.asarray(rotation).T
        datasets["/lights/direction"] = directions
        datasets["/lights/irradiance"] = fit.irradiance
        if light_shape == "sphere":
            datasets["/lights/angular_radius"] = fit.radii
        dattrs["/lights/direction"] = {
            "requested": str(lights),
            **({"tolerance": float(light_tol)} if lights == "auto" else {}),
            "fit_directions": FIT_DIRECTIONS,
            "fit_mean_error": fit.mean_error,
            "fit_max_error": fit.max_error,
        }
    if fit is None:
        if projection is None:
            projection = project_lighting(env, lmax, radius)
        light, L = projection.light, projection.sh
    else:
        L = _with_fit(env.project(lmax), fit, irradiance_lmax)
    if sun:
        summary["sun"] = dict(projection.sun_report)  # the caller's to add to
        if light is not None:
            datasets["/sun/direction"] = (light.direction if rotation is None
                                          else np.asarray(rotation) @ light.direction)  # fmt: skip
            datasets["/sun/solid_angle"] = np.float64(light.solid_angle)
            datasets["/sun/radiance"] = light.radiance
            dattrs["/sun/direction"] = {"frame": "world, unit vector toward the light"}
            dattrs["/sun/radiance"] = {"units": "radiance; radiance * solid_angle = irradiance"}
    if rotation is not None:
        L = rotate(L, rotation)
    datasets["/lighting/sh"] = L
    dattrs["/lighting/sh"] = {
        "lmax": lmax,
        "sun_removed": light is not None,
        "quadrature": "fejer-1 rows" if env.layout == "latlong" else "exact texel solid angles",
        **({"lights_fitted": True} if fit is not None else {}),
    }
    datasets["/lighting/band_energy"] = band_energy(L)

    kernels = []
    if irradiance:
        kernels.append(lambert_kernel(irradiance_lmax))
    if tangent:
        kernels.append(kajiya_kay_kernel(irradiance_lmax))
    n_irr = (irradiance_lmax + 1) ** 2
    L_irr = L[:n_irr]
    win_attrs = {"method": window_name, "lmax": irradiance_lmax}
    if window_name == "dering" and kernels:
        w, minimum = dering_window(L_irr, kernels)
        win_attrs["reconstruction_minimum"] = float(minimum)
        summary["dering_minimum"] = float(minimum)
    elif window_name == "dering":
        w = np.ones(irradiance_lmax + 1)
    else:
        w = window(window_name, irradiance_lmax)
    datasets["/lighting/window"] = w
    dattrs["/lighting/window"] = win_attrs
    bands = band_of_index(irradiance_lmax)
    if irradiance:
        datasets["/irradiance/sh"] = L_irr * (lambert_kernel(irradiance_lmax) * w)[bands][:, None]
        dattrs["/irradiance/sh"] = {"lmax": irradiance_lmax, "kernel": "lambert clamped cosine"}
    if tangent:
        E_t = L_irr * (kajiya_kay_kernel(irradiance_lmax) * w)[bands][:, None]
        datasets["/tangent_irradiance/sh"] = E_t
        dattrs["/tangent_irradiance/sh"] = {"lmax": irradiance_lmax, "kernel": "kajiya-kay diffuse"}
        if irradiance_lmax >= 2:
            datasets["/tangent_irradiance/matrix"] = matrix_form(L_irr[:9] * w[bands[:9]][:, None])
            dattrs["/tangent_irradiance/matrix"] = {"form": "E(t) = [t,1]^T M [t,1], Mehta eq. 23"}
    summary["bake_seconds"] = time.perf_counter() - t0
    attrs = map_source(env.meta) | dict(provenance or {})
    return Asset("env_sh", attrs, datasets, dattrs), summary


def check_lights(lights, tol: float, sun: bool, window_name: str,
                 shape: str = "point") -> None:  # fmt: skip
    """Refuse light settings :func:`bake_env_sh` cannot honour (before any map is read)."""
    if shape not in SHAPES:
        raise ParameterError(f"--light-shape must be one of {', '.join(SHAPES)}, got {shape!r}")
    if lights is None:
        if shape != "point":
            raise ParameterError("--light-shape applies to --lights only")
        return
    if lights != "auto" and not (
        isinstance(lights, int) and not isinstance(lights, bool) and 0 <= lights <= MAX_LIGHTS
    ):
        raise ParameterError(f"--lights must be auto or 0…{MAX_LIGHTS}, got {lights!r}")
    if not 0.0 < tol < 1.0:
        raise ParameterError(f"--tol must be in (0, 1), got {tol}")
    if sun:
        raise ParameterError("--lights and --extract-sun exclude each other "
                             "(--lights 1 fits one light to the irradiance)")  # fmt: skip
    if window_name != "none":
        raise ParameterError("--lights fits the irradiance itself: no --window with it")


def _fit(env: Environment, lights, tol: float, lmax: int, shape: str):
    """The light fit ``--lights`` asks for and its summary (each fit tried: its errors)."""
    if lights == "auto":
        fit, tried = choose_lights(irradiance_target(env), tol, AUTO_MAX_LIGHTS, lmax,
                                   shape=shape)  # fmt: skip
    else:
        *_, fit = light_chain(irradiance_target(env), lights, lmax, shape)
        tried = [fit]
    summary = {
        "requested": lights,
        "count": fit.count,
        "mean_error": fit.mean_error,
        "max_error": fit.max_error,
        "rms_error": fit.rms_error,
        "fit_directions": FIT_DIRECTIONS,
        "tried": [{"count": f.count, "mean_error": f.mean_error, "max_error": f.max_error}
                  for f in tried],  # fmt: skip
        "shape": shape,
        "energy_fraction": ((sphere_power(fit.radii) @ fit.irradiance)
                            / np.where(env.total_energy() > 0, env.total_energy(), 1.0)).tolist(),
    }  # fmt: skip
    if lights == "auto":
        summary["tolerance"] = tol
        summary["met"] = fit.mean_error <= tol
    return fit, summary


def _with_fit(L: np.ndarray, fit, irradiance_lmax: int) -> np.ndarray:
    """The residual's lighting SH with lights: the map's projection less the lights (delta
    lights of their energy; spheres: times their band factors ``g_l``), then the bands the
    Lambert kernel sees up to ``irradiance_lmax`` replaced by the fitted irradiance SH over
    ``Â_l``."""
    lmax = lmax_of(L.shape[0])
    out = L - lights_sh(fit.directions, fit.irradiance, fit.radii, lmax)
    a = lambert_kernel(irradiance_lmax)[band_of_index(irradiance_lmax)]
    seen = np.flatnonzero(a != 0.0)
    out[seen] = fit.sh[seen] / a[seen, None]
    return out


def _jsonable(d: dict) -> dict:
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in d.items()}


def truncation_report(env: Environment, lmax: int, irradiance_lmax: int) -> dict:
    """Energy per band and the error the chosen ``lmax`` implies (RH02 §5.1).

    Projects to ``max(lmax, 64)`` once and reports, per channel, the fraction
    of ``∫ L² dω`` captured up to ``lmax`` (``1 - ε_L``), and for the Lambert
    and Kajiya–Kay kernels the fraction of the *convolved* energy
    ``Σ K_l² e_l`` lost beyond ``irradiance_lmax``.
    """
    top = max(lmax, REPORT_LMAX)
    top = min(top, env.shape[1] // 2 - 1) if env.layout == "latlong" else top
    L = env.project(top)
    e = band_energy(L)
    w = env.quadrature_weights()
    total = np.einsum("hwc,hw->c", env.pixels.astype(np.float64) ** 2, w)
    captured = e[: lmax + 1].sum(axis=0) / np.where(total > 0, total, 1.0)
    rep = {
        "band_energy": e[: lmax + 1].tolist(),
        "lighting_energy_captured": captured.tolist(),
        "lighting_epsilon": (1.0 - captured).tolist(),
    }
    for name, kernel in (("irradiance", lambert_kernel), ("tangent_irradiance", kajiya_kay_kernel)):
        k2 = kernel(top)[:, None] ** 2 * e
        lost = k2[irradiance_lmax + 1 :].sum(axis=0) / np.maximum(k2.sum(axis=0), 1e-300)
        rep[f"{name}_energy_lost"] = lost.tolist()
    return rep
