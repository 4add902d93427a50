"""What an engine's shader does with an ``env_sh`` asset: SH irradiance plus its lights.

Lambert (``/irradiance/sh``, ``Â_l`` folded in, SPEC §4)::

    E(n) = Σ_i c_i y_i(n) + Σ_k max(0, n·s_k) E_k

Kajiya–Kay tangent irradiance (Mehta et al. 2012), from ``/tangent_irradiance/sh``
(``A_l`` folded in) or the 4×4 matrix of eq. 23–24 (``/tangent_irradiance/matrix``)::

    E(t) = Σ_i c_i y_i(t) + Σ_k sqrt(1 − (t·s_k)²)/π² E_k = t̃ᵀ M t̃ + Σ_k sqrt(1 − (t·s_k)²)/π² E_k

with ``s_k`` a light's direction and ``E_k`` its irradiance at normal incidence: the
extracted sun (``/sun``: ``E = radiance × solid_angle``) or the fitted lights
(``/lights``); none when the asset has neither.
Kernels are check-free: directions unit, arrays from a validated asset.
"""

import numpy as np

from shbake.jit import jit, run_blocks
from shbake.sh.basis import evaluate

INV_PI2 = 1.0 / (np.pi * np.pi)


@jit
def sun_lambert(c):
    """Lambert factor ``max(0, n·s)`` of a directional light, ``c = n·s`` (``py_func``: arrays)."""
    return np.maximum(c, 0.0)


@jit
def sun_tangent(c):
    """Kajiya–Kay diffuse factor ``sqrt(1 − (t·s)²)/π²`` of a directional light, ``c = t·s``
    (``py_func``: arrays)."""
    return np.sqrt(np.maximum(0.0, 1.0 - c * c)) * INV_PI2


@jit
def _matrix_with_lights(tangents, M, light_dirs, light_energy, out, b0, b1):
    for p in range(b0, b1):
        t = (tangents[p, 0], tangents[p, 1], tangents[p, 2], 1.0)
        for ch in range(3):
            e = 0.0
            for r in range(4):
                for s in range(4):
                    e += t[r] * M[ch, r, s] * t[s]
            out[p, ch] = e
        for j in range(light_dirs.shape[0]):
            d = light_dirs[j]
            k = sun_tangent(t[0] * d[0] + t[1] * d[1] + t[2] * d[2])
            for ch in range(3):
                out[p, ch] += k * light_energy[j, ch]


def lights_of(asset):
    """``(directions (K, 3), E (K, 3))`` of an ``env_sh`` asset's lights: its sun
    (``E = radiance × solid_angle``) or its fitted ``/lights``; ``K = 0`` without."""
    if "/sun/direction" in asset:
        return (
            np.asarray(asset["/sun/direction"], float).reshape(1, 3),
            (np.asarray(asset["/sun/radiance"], float) * float(asset["/sun/solid_angle"]))[None],
        )
    if "/lights/direction" in asset:
        return (
            np.asarray(asset["/lights/direction"], float).reshape(-1, 3),
            np.asarray(asset["/lights/irradiance"], float).reshape(-1, 3),
        )
    return np.zeros((0, 3)), np.zeros((0, 3))


def _flat(dirs):
    d = np.asarray(dirs, dtype=np.float64)
    return d, np.ascontiguousarray(d.reshape(-1, 3))


def irradiance(asset, dirs, tangent: bool = False) -> np.ndarray:
    """Irradiance ``(..., 3)`` of an ``env_sh`` asset at unit ``dirs (..., 3)``, sun included.

    ``tangent``: Kajiya–Kay tangent irradiance from ``/tangent_irradiance/sh`` at unit
    tangents instead of Lambert irradiance at normals.
    """
    coeffs = np.ascontiguousarray(
        asset["/tangent_irradiance/sh" if tangent else "/irradiance/sh"], dtype=np.float64
    )
    d, flat = _flat(dirs)
    out = evaluate(coeffs, flat)  # fused and blocked (numpy for small jobs): sh.basis
    factor = (sun_tangent if tangent else sun_lambert).py_func
    for direction, energy in zip(*lights_of(asset), strict=True):
        if energy.any():
            out += factor(flat @ direction)[:, None] * energy
    return out.reshape(d.shape[:-1] + (3,))


def tangent_irradiance_matrix(asset, tangents) -> np.ndarray:
    """Tangent irradiance ``(..., 3)`` by the matrix form (Mehta eq. 23) plus the lights."""
    M = np.ascontiguousarray(asset["/tangent_irradiance/matrix"], dtype=np.float64)
    d, flat = _flat(tangents)
    out = np.empty((flat.shape[0], 3))
    dirs, energy = lights_of(asset)
    run_blocks(_matrix_with_lights, flat.shape[0], flat.shape[0] * (110.0 + 20.0 * len(dirs)),
               flat, M, np.ascontiguousarray(dirs), np.ascontiguousarray(energy), out)  # fmt: skip
    return out.reshape(d.shape[:-1] + (3,))
