"""The ground truth each shader approximates, by name (a shader's ``truth``).

:data:`TRUTHS` maps the name to the brute-force integral over the original map that a
shader's :meth:`~shbake.shading.shader.Shader.shade` approximates, in the same units
(outgoing radiance ``(N, 3)`` toward ``views``) and for the same material:

``irradiance``
    ``ρ E(n) / π``, ``E`` by :func:`~shbake.reference.irradiance.brute_force_irradiance`;
``tangent``
    ``k_d E(t)``, the Kajiya–Kay tangent irradiance, same function;
``brdf``
    :func:`~shbake.reference.brdf_shading.brute_force_shading` with the BRDF a Kautz
    table tabulates (``merl_path``: its measured data, the file the user gave, whose bytes
    must hash to ``merl_sha256`` when given), in the shader's frames;
``ggx``
    ``F0 E0 + (1 − F0) E1`` by :func:`~shbake.reference.ggx.ggx_integrals` (``samples``
    per pixel; lat-long maps);
``reflection``
    :func:`~shbake.reference.reflection.brute_force_reflection` of the BRDF an SHRM baked
    (``merl_path``, ``merl_sha256``: a measured one's data, as for ``brdf``).

Each takes ``(shader, env, normals, views, tangents, **settings)`` and reads from the
shader only what describes the BRDF (never its coefficients): the references stay
independent of the SH machinery they check. ``rotation``: the map seen turned by ``R``
(a scene probe's pose): its texel directions turned, or (the lat-long GGX integrals, which
take the map as it is) the normals and views turned back by ``Rᵀ``, the same integral.
"""

import numpy as np

from shbake.reference.brdf_shading import brute_force_shading
from shbake.reference.ggx import ggx_integrals
from shbake.reference.irradiance import brute_force_irradiance
from shbake.reference.reflection import brute_force_reflection

INV_PI = 1.0 / np.pi


def _samples(env, rotation=None):
    dirs, omega, radiance = env.samples()
    if rotation is not None:
        dirs = dirs @ np.asarray(rotation).T  # the map's d is seen at R d
    return dirs, omega, radiance


def irradiance_truth(shader, env, normals, views, tangents=None, rotation=None, albedo=1.0,
                     **settings):  # fmt: skip
    e = brute_force_irradiance(*_samples(env, rotation), np.asarray(normals), tangent=False)
    return e * (np.asarray(albedo, dtype=np.float64) * INV_PI)


def tangent_truth(shader, env, normals, views, tangents=None, rotation=None, kd=1.0,
                  **settings):  # fmt: skip
    e = brute_force_irradiance(*_samples(env, rotation), np.asarray(tangents), tangent=True)
    return e * np.asarray(kd, dtype=np.float64)


def brdf_truth(shader, env, normals, views, tangents=None, rotation=None, merl_path=None,
               merl_sha256=None, **settings):  # fmt: skip
    frames, local = shader.frames(normals, views, tangents)
    return brute_force_shading(*_samples(env, rotation), frames, local,
                               shader.table.make_brdf(merl_path, merl_sha256))  # fmt: skip


def ggx_truth(shader, env, normals, views, tangents=None, rotation=None, alpha=None, f0=1.0,
              samples=4096, **settings):  # fmt: skip
    if rotation is not None:  # the turned map at R d is the map at d: shade Rᵀn, Rᵀv under it
        turn = np.asarray(rotation, dtype=np.float64)
        normals = np.ascontiguousarray(np.asarray(normals, dtype=np.float64) @ turn)
        views = np.ascontiguousarray(np.asarray(views, dtype=np.float64) @ turn)
    e0, e1 = ggx_integrals(env.pixels, views, normals, alpha, samples)
    return f0 * e0 + (1.0 - f0) * e1


def reflection_truth(shader, env, normals, views, tangents=None, rotation=None, merl_path=None,
                     merl_sha256=None, **settings):  # fmt: skip
    model, params, _ = shader.brdf()  # the recorded MERL source is not followed (``merl_path``)
    view = np.asarray(views, dtype=np.float64).reshape(-1, 3)[0]
    return brute_force_reflection(*_samples(env, rotation), shader.kind, model, params,
                                  normals, view, tangents, merl_path or "",
                                  merl_sha256)  # fmt: skip


TRUTHS = {
    "irradiance": irradiance_truth,
    "tangent": tangent_truth,
    "brdf": brdf_truth,
    "ggx": ggx_truth,
    "reflection": reflection_truth,
}
"""Truth name → function (module docstring)."""


def truth(shader, env, normals, views, tangents=None, **settings) -> np.ndarray:
    """The ground truth of ``shader`` (:data:`TRUTHS` of its ``truth``) under ``env``."""
    return TRUTHS[shader.truth](shader, env, normals, views, tangents, **settings)
