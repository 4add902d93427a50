"""How far an ``env_sh`` asset's irradiance is from brute force of the original map."""

import numpy as np

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap.environment import Environment
from shbake.format.asset import Asset
from shbake.progress import NO_PROGRESS
from shbake.reference.irradiance import brute_force_irradiance
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.env_sh import irradiance

QUERY_CHUNK = 128
"""Query directions per brute-force call (one progress step)."""


def brute_force_reference(env: Environment, n_dirs: int = 2048, progress=NO_PROGRESS) -> dict:
    """Brute-force luminance of irradiance and tangent irradiance of ``env``.

    Queries: ``n_dirs`` spherical-Fibonacci directions. Returns
    ``{"dirs": (n, 3), "irradiance": (n,), "tangent_irradiance": (n,)}``.
    Cost ``O(texels × n_dirs)``: minutes on a 4K map, hence ``progress``.
    """
    dirs, omega, radiance = env.samples()
    q = fibonacci_sphere(n_dirs)
    out = {"dirs": q}
    chunks = range(0, n_dirs, QUERY_CHUNK)
    with progress.task("brute-force irradiance", total=2 * len(chunks), unit="chunk") as advance:
        for name, tangent in (("irradiance", False), ("tangent_irradiance", True)):
            parts = []
            for s in chunks:
                e = brute_force_irradiance(dirs, omega, radiance, q[s : s + QUERY_CHUNK], tangent)
                parts.append(e @ REC709_LUMINANCE)
                advance(1)
            out[name] = np.concatenate(parts)
    return out


def irradiance_errors(
    asset: Asset, env: Environment, reference: dict | None = None, progress=NO_PROGRESS
) -> dict:
    """Luminance relative error of the asset's irradiance vs brute force of ``env``.

    ``env`` is the original map (before sun extraction); ``reference`` a
    :func:`brute_force_reference` of it, computed here when omitted. Returns,
    for ``irradiance`` and ``tangent_irradiance`` when present,
    ``{"mean": …, "max": …}`` of ``|Y(E) - Y(E_ref)| / Y(E_ref)``.
    """
    ref = reference if reference is not None else brute_force_reference(env, progress=progress)
    out = {}
    for name, tangent in (("irradiance", False), ("tangent_irradiance", True)):
        if f"/{name}/sh" not in asset:
            continue
        got = irradiance(asset, ref["dirs"], tangent=tangent) @ REC709_LUMINANCE
        rel = np.abs(got - ref[name]) / np.maximum(ref[name], 1e-30)
        out[name] = {"mean": float(rel.mean()), "max": float(rel.max())}
    return out
