"""Helpers shared by the sampling strategies of the BRDF models, and local shading frames.

Lobe samplers map ``(u_r, u_a) ∈ [0, 1)²`` — a radial and an azimuthal
coordinate — to a direction; :mod:`shbake.brdf.tabulate` integrates over that
square with a product rule (Gauss–Legendre × midpoint; nested Clenshaw–Curtis ×
trapezoid when refining to a tolerance).
"""

import numpy as np

from shbake.jit import jit

INV_PI = 1.0 / np.pi
TWO_PI = 2.0 * np.pi


@jit
def cosine_pdf(sz):
    """Solid-angle density ``cos θ / π`` of cosine-weighted hemisphere directions at
    ``z = sz`` (0 below the surface): the weight of the hemisphere rule against a lobe's
    own density in :mod:`shbake.brdf.tabulate`'s multiple importance sampling."""
    return sz * INV_PI if sz > 0.0 else 0.0


@jit
def reflect_about(hx, hy, hz, vx, vy, vz):
    """``2 (v·h) h − v`` for unit ``h``."""
    d = 2.0 * (vx * hx + vy * hy + vz * hz)
    return d * hx - vx, d * hy - vy, d * hz - vz


@jit
def tangent_frame(nx, ny, nz):
    """Tangent and bitangent completing the unit vector ``n`` (Duff et al. 2017, branchless)."""
    sign = 1.0 if nz >= 0.0 else -1.0
    e = -1.0 / (sign + nz)
    f = nx * ny * e
    return (1.0 + sign * nx * nx * e, sign * f, -sign * nx), (f, sign + ny * ny * e, -ny)


@jit
def surface_frame(vx, vy, vz, nx, ny, nz):
    """Tangent ``t``, bitangent ``b`` of ``n`` (:func:`tangent_frame`) and ``v`` in that frame."""
    (tx, ty, tz), (bx, by, bz) = tangent_frame(nx, ny, nz)
    v_loc = (tx * vx + ty * vy + tz * vz, bx * vx + by * vy + bz * vz, nx * vx + ny * vy + nz * vz)
    return (tx, ty, tz), (bx, by, bz), v_loc


@jit
def lobe_frame_dir(ax, ay, az, ct, cphi, sphi):
    """Direction at polar angle ``acos(ct)`` about the unit axis ``a``, azimuth ``φ`` given
    by ``cphi, sphi = cos φ, sin φ``."""
    st = np.sqrt(max(0.0, 1.0 - ct * ct))
    (tx, ty, tz), (bx, by, bz) = tangent_frame(ax, ay, az)
    cp, sp = cphi * st, sphi * st
    return (
        cp * tx + sp * bx + ct * ax,
        cp * ty + sp * by + ct * ay,
        cp * tz + sp * bz + ct * az,
    )


@jit
def safe_pow(c, n):
    """``max(c, 0)^n`` for ``n ≥ 0`` without overflow or ``0^0`` surprises (``0^0 = 1``)."""
    if n == 0.0:
        return 1.0
    if c <= 0.0:
        return 0.0
    return np.exp(n * np.log(c))


def fibre_frames(normals, tangents) -> np.ndarray:
    """World → local rotations ``(N, 3, 3)`` whose rows are the unit ``tangents`` (local +X),
    ``normals × tangents`` (+Y) and the unit ``normals`` (+Z): the local shading frame
    (SPEC §3) brushed along a given tangent (the Kautz pass's, anisotropic lobes along it).

    >>> fibre_frames([[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])[0].tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    n = np.asarray(normals, dtype=np.float64)
    t = np.asarray(tangents, dtype=np.float64)
    return np.ascontiguousarray(np.stack([t, np.cross(n, t), n], axis=1))
