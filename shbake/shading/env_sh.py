"""What an engine's shader does with an ``env_sh`` asset: SH irradiance plus the sun.

Lambert (``/irradiance/sh``, ``Â_l`` folded in, SPEC §4)::

    E(n) = Σ_i c_i y_i(n) + max(0, n·s) E_sun

Kajiya–Kay tangent irradiance (Mehta et al. 2012), from ``/tangent_irradiance/sh``
(``A_l`` folded in) or the 4×4 matrix of eq. 23–24 (``/tangent_irradiance/matrix``)::

    E(t) = Σ_i c_i y_i(t) + sqrt(1 − (t·s)²)/π² E_sun = t̃ᵀ M t̃ + sqrt(1 − (t·s)²)/π² E_sun

with ``s`` the sun's direction and ``E_sun = radiance × solid_angle`` its
irradiance at normal incidence (``/sun``, absent when no sun was extracted).
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
def _matrix_with_sun(tangents, M, sun_dir, sun_energy, out, b0, b1):
    for p in range(b0, b1):
        t = (tangents[p, 0], tangents[p, 1], tangents[p, 2], 1.0)
        k = sun_tangent(t[0] * sun_dir[0] + t[1] * sun_dir[1] + t[2] * sun_dir[2])
        for ch in range(3):
            e = k * sun_energy[ch]
            for r in range(4):
                for s in range(4):
                    e += t[r] * M[ch, r, s] * t[s]
            out[p, ch] = e


def sun_of(asset):
    """``(direction, E_sun)`` of an ``env_sh`` asset; a zero light when it has none."""
    if "/sun/direction" in asset:
        return (
            np.asarray(asset["/sun/direction"], float),
            np.asarray(asset["/sun/radiance"], float) * float(asset["/sun/solid_angle"]),
        )
    return np.array([0.0, 0.0, 1.0]), np.zeros(3)


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
    sun_dir, sun_energy = sun_of(asset)
    if sun_energy.any():
        k = (sun_tangent if tangent else sun_lambert).py_func(flat @ sun_dir)
        out += k[:, None] * sun_energy
    return out.reshape(d.shape[:-1] + (3,))


def tangent_irradiance_matrix(asset, tangents) -> np.ndarray:
    """Tangent irradiance ``(..., 3)`` by the matrix form (Mehta eq. 23) plus the sun."""
    M = np.ascontiguousarray(asset["/tangent_irradiance/matrix"], dtype=np.float64)
    d, flat = _flat(tangents)
    out = np.empty((flat.shape[0], 3))
    run_blocks(_matrix_with_sun, flat.shape[0], flat.shape[0] * 110.0, flat, M, *sun_of(asset), out)
    return out.reshape(d.shape[:-1] + (3,))
