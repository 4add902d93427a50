"""Kautz et al. 2002 §4 shading of a BRDF table under SH lighting: rotate, fetch, dot.

Per shading point with world → local frame ``R`` (rows: tangent, bitangent,
normal) and local view ``v``:

1. rotate the lighting coefficients into the local frame, ``L_p = M(R) L``;
2. (the caller rotates the view vector, ``v_p = R v``);
3. fetch ``c(v_p)`` from the parabolic table, bilinearly;
4. ``Q = Σ_i L_p,i c_i(v_p)`` per channel.

Fixed light: ``L_p`` is computed once, a frame costs steps 2–4. Fixed view:
``M(R)ᵀ c(v_p)`` is computed once, a frame (a lighting change) costs one dot
product per point. A sun extracted into the environment asset is added to
``L`` as the SH projection of a directional light, ``E_sun y_i(s)``,
band-limited like the rest.
"""

import numpy as np

from shbake.errors import ParameterError
from shbake.jit import jit, pjit, prange
from shbake.sh.basis import real_sh
from shbake.sh.rotation import rotation_blocks_with, rotation_coefficients
from shbake.texture.parabolic import fetch_into

PIXEL_BLOCK = 64
"""Pixels per work item of the per-pixel rotations: scratch is allocated once per block."""


@jit
def frame_blocks_into(R, lmax, offsets, uvw, r1, flat):
    """Flat per-band blocks of ``M(R)`` into the preallocated ``flat`` (every entry written).

    ``uvw`` from :func:`~shbake.sh.rotation.rotation_coefficients` (once per
    call, not per pixel); ``r1`` (3×3) is scratch for the ``l = 1`` block
    (``R`` permuted, see rotation.py).
    """
    for i in range(3):
        for j in range(3):
            r1[i, j] = R[(i + 1) % 3, (j + 1) % 3]
    rotation_blocks_with(r1, lmax, offsets, uvw, flat)


@jit
def frame_blocks(R, lmax, offsets):
    """Flat per-band blocks of ``M(R)`` (a new array; see :func:`frame_blocks_into`)."""
    flat = np.zeros(offsets[-1])
    uvw = np.empty(3 * offsets[-1])
    rotation_coefficients(lmax, offsets, uvw)
    frame_blocks_into(R, lmax, offsets, uvw, np.empty((3, 3)), flat)
    return flat


@pjit
def rotate_lighting(frames, L, lmax, offsets, out):
    """``out[p] = M(R_p) L`` (block-diagonal), for every pixel.

    The recurrence's ``u, v, w`` factors are computed once per call; pixels go
    in blocks of :data:`PIXEL_BLOCK`, each allocating its rotation scratch
    once and rebuilding the blocks in place per pixel.
    """
    n_pix = frames.shape[0]
    uvw = np.empty(3 * offsets[-1])
    rotation_coefficients(lmax, offsets, uvw)
    for blk in prange((n_pix + PIXEL_BLOCK - 1) // PIXEL_BLOCK):
        r1 = np.empty((3, 3))
        flat = np.empty(offsets[-1])
        for p in range(blk * PIXEL_BLOCK, min(n_pix, (blk + 1) * PIXEL_BLOCK)):
            frame_blocks_into(frames[p], lmax, offsets, uvw, r1, flat)
            for l in range(lmax + 1):
                size = 2 * l + 1
                o = offsets[l]
                base = l * l
                for i in range(size):
                    for c in range(3):
                        acc = 0.0
                        for j in range(size):
                            acc += flat[o + i * size + j] * L[base + j, c]
                        out[p, base + i, c] = acc


@pjit
def rotate_coeffs_to_world(frames, views, table, lmax, offsets, out):
    """``out[p] = M(R_p)ᵀ c(v_p)`` (the fixed-view precomputation)."""
    n = (lmax + 1) * (lmax + 1)
    for p in prange(frames.shape[0]):
        flat = frame_blocks(frames[p], lmax, offsets)
        c = np.empty((n, 3))
        fetch_into(table, views[p, 0], views[p, 1], views[p, 2], c)
        for l in range(lmax + 1):
            size = 2 * l + 1
            blk = flat[offsets[l] : offsets[l + 1]].reshape((size, size))
            base = l * l
            for j in range(size):
                for ch in range(3):
                    acc = 0.0
                    for i in range(size):
                        acc += blk[i, j] * c[base + i, ch]
                    out[p, base + j, ch] = acc


@pjit
def lookup_dot(views, table, L_local, out):
    """Steps 3–4 with pre-rotated lighting (fixed-light frame)."""
    n = table.shape[2]
    for p in prange(views.shape[0]):
        c = np.empty((n, 3))
        fetch_into(table, views[p, 0], views[p, 1], views[p, 2], c)
        for ch in range(3):
            acc = 0.0
            for i in range(n):
                acc += L_local[p, i, ch] * c[i, ch]
            out[p, ch] = acc


@pjit
def dot_world(coeffs_world, L, out):
    """The fixed-view frame: ``Q = Σ_i L_i (M(R_p)ᵀ c)_i``."""
    n = L.shape[0]
    for p in prange(coeffs_world.shape[0]):
        for ch in range(3):
            acc = 0.0
            for i in range(n):
                acc += L[i, ch] * coeffs_world[p, i, ch]
            out[p, ch] = acc


def lighting_with_sun(env_asset, lmax: int) -> np.ndarray:
    """``(n, 3)`` world lighting coefficients of an ``env_sh`` asset, sun folded in as SH."""
    L = np.asarray(env_asset["/lighting/sh"], dtype=float)
    n = (lmax + 1) ** 2
    if L.shape[0] < n:
        have = int(round(np.sqrt(L.shape[0]))) - 1
        raise ParameterError(
            f"the environment asset has lighting to lmax {have}; the table needs {lmax}"
        )
    L = L[:n].copy()
    if "/sun/direction" in env_asset:
        e = env_asset["/sun/radiance"] * float(env_asset["/sun/solid_angle"])
        L += real_sh(env_asset["/sun/direction"], lmax)[:, None] * e[None, :]
    return np.ascontiguousarray(L)
