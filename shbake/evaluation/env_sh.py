"""How far an ``env_sh`` asset's irradiance is from brute force of the original map."""

import numpy as np

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap.environment import Environment
from shbake.evaluation.metrics import max_relative_error, mean_relative_error, relative_rms_error
from shbake.format.asset import Asset
from shbake.progress import NO_PROGRESS
from shbake.reference.irradiance import brute_force_irradiance
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.shader import shader

QUERY_CHUNK = 128
"""Query directions per brute-force call (one progress step)."""
EXPORT_COEFFS = 9
"""Irradiance SH coefficients every SH export target carries (lmax 2, docs/EXPORTS.md)."""


CHECK_DIRECTIONS = 256
"""Fibonacci directions of a scene bake's irradiance check (:func:`check_reference`): its
relative RMS error agrees with 4096 directions' within 1.1 % of the error itself on the
shared maps (lmax 2 and 4, sun kept and extracted; ``tests/batch/test_scene.py``)."""
IRRADIANCE_NAMES = ("irradiance", "tangent_irradiance")


def brute_force_reference(env: Environment, n_dirs: int = 2048, progress=NO_PROGRESS,
                          names=IRRADIANCE_NAMES) -> dict:  # fmt: skip
    """Brute-force luminance of irradiance and tangent irradiance of ``env``.

    Queries: ``n_dirs`` spherical-Fibonacci directions. Returns
    ``{"dirs": (n, 3), "irradiance": (n,), "tangent_irradiance": (n,)}`` (those of
    ``names`` only). Cost ``O(texels × n_dirs)``: minutes on a 4K map, hence ``progress``.
    """
    dirs, omega, radiance = env.samples()
    q = fibonacci_sphere(n_dirs)
    out = {"dirs": q}
    chunks = range(0, n_dirs, QUERY_CHUNK)
    kinds = [(n, n == "tangent_irradiance") for n in IRRADIANCE_NAMES if n in names]
    with progress.task("brute-force irradiance", total=len(kinds) * len(chunks),
                       unit="chunk") as advance:  # fmt: skip
        for name, tangent in kinds:
            parts = []
            for s in chunks:
                e = brute_force_irradiance(dirs, omega, radiance, q[s : s + QUERY_CHUNK], tangent)
                parts.append(e @ REC709_LUMINANCE)
                advance(1)
            out[name] = np.concatenate(parts)
    return out


def check_reference(env: Environment, names, n_dirs: int = CHECK_DIRECTIONS) -> dict:
    """The reference of a scene bake's check (:func:`brute_force_reference`'s keys, those of
    ``names``), each as cheap as the bake and still the brute-force sum: Lambert irradiance
    summed over the map's solid-angle pyramid (exactly the brute-force sum,
    :mod:`shbake.reference.irradiance_pyramid`), tangent irradiance texel by texel (no
    pyramid identity), at ``n_dirs`` Fibonacci directions. ``"methods"``: how each was
    measured (``direction-set-pyramid`` or ``brute-force``), what the lock records."""
    from shbake.reference.irradiance_pyramid import IrradiancePyramid

    q = fibonacci_sphere(n_dirs)
    out = {"dirs": q, "methods": {}}
    if "irradiance" in names:
        out["irradiance"] = IrradiancePyramid(env).irradiance(q) @ REC709_LUMINANCE
        out["methods"]["irradiance"] = "direction-set-pyramid"
    if "tangent_irradiance" in names:
        dirs, omega, radiance = env.samples()
        out["tangent_irradiance"] = brute_force_irradiance(dirs, omega, radiance, q, True) @ (
            REC709_LUMINANCE
        )
        out["methods"]["tangent_irradiance"] = "brute-force"
    return out


def irradiance_errors(
    asset: Asset, env: Environment, reference: dict | None = None, progress=NO_PROGRESS,
    rotation=None,
) -> dict:  # fmt: skip
    """Luminance errors of the asset's irradiance vs brute force of ``env``.

    ``env`` is the original map (before sun extraction); ``reference`` a
    :func:`brute_force_reference` of it, computed here when omitted; ``rotation``: the
    asset's SH were turned by ``R`` from the map's (a scene probe's pose), so the asset at
    ``R d`` is compared with the map at ``d``. Returns, for ``irradiance`` and
    ``tangent_irradiance`` when present (shaders ``irradiance`` and ``tangent-sh`` of the
    registry), ``{"mean": …, "max": …, "relative_rms": …}``: the mean and the largest
    pointwise relative error ``|Y(E) − Y(E_ref)| / Y(E_ref)`` and the relative RMS error
    (:mod:`shbake.evaluation.metrics`; the scene's tolerances are relative RMS).
    """
    ref = reference if reference is not None else brute_force_reference(env, progress=progress)
    dirs = ref["dirs"] if rotation is None else ref["dirs"] @ np.asarray(rotation).T
    out = {}
    for name, technique in (("irradiance", "irradiance"), ("tangent_irradiance", "tangent-sh")):
        if f"/{name}/sh" not in asset:
            continue
        got = shader(asset, technique).irradiance(dirs) @ REC709_LUMINANCE
        out[name] = {
            "mean": mean_relative_error(got, ref[name]),
            "max": max_relative_error(got, ref[name]),
            "relative_rms": relative_rms_error(got, ref[name]),
        }
    return out


def export_irradiance_errors(
    asset: Asset, env: Environment, reference: dict | None = None, progress=NO_PROGRESS,
    rotation=None, coeffs: int | None = EXPORT_COEFFS,
) -> dict:  # fmt: skip
    """Luminance errors of the irradiance an engine evaluates from an SH export of the asset
    (the first ``coeffs`` coefficients of ``/irradiance/sh`` — :data:`EXPORT_COEFFS`, what
    every engine target writes; ``None``: all of them, what ``--to webgl`` draws — and the
    asset's lights) against brute force of ``env``, as :func:`irradiance_errors` measures the
    asset's own: ``{"mean", "max", "relative_rms"}``. The frame a target turns both into
    changes none of them."""
    cut = Asset(asset.kind, asset.attrs, {
        k: (v[:coeffs] if k == "/irradiance/sh" else v)
        for k, v in asset.datasets.items() if not k.startswith("/tangent_irradiance")})  # fmt: skip
    return irradiance_errors(cut, env, reference, progress, rotation)["irradiance"]
