"""The ``kautz`` pass: a BRDF table shaded under SH lighting (Kautz et al. 2002, §4).

Per pixel ``p`` of the preview sphere (orthographic camera on +Z, view
``v' = +Z``): the local frame ``R_p`` has the normal as +Z and, as +X, the
brushing direction — world +Y projected on the tangent plane (the paper's
"constant vector projected to the tangent space"), so anisotropic lobes run
along the sphere's meridians. The paper's four steps:

1. rotate the lighting coefficients into the local frame, ``L_p = M(R_p) L``;
2. rotate the view vector, ``v_p = R_p v'``;
3. fetch ``c(v_p)`` from the parabolic table, bilinearly;
4. ``Q = Σ_i L_p,i c_i(v_p)`` per channel.

Fixed light (§4): ``L_p`` is computed once; a frame costs steps 2–4.
Fixed view: ``M(R_p)ᵀ c(v_p)`` is computed once; a frame (a lighting
change) costs one dot product per pixel. Each mode is timed separately.
A sun extracted into the environment asset is added to ``L`` as the SH
projection of a directional light, ``E_sun y_i(s)``, band-limited like the rest.
"""

import time

import numba
import numpy as np

from shbake.brdf.lookup import fetch_into
from shbake.errors import ParameterError
from shbake.jit import jit, pjit
from shbake.preview.sphere import sphere_geometry
from shbake.sh.basis import real_sh
from shbake.sh.rotation import _block_offsets, _rotation_blocks


@jit
def _frame_blocks(R, lmax, offsets):
    """Flat per-band blocks of ``M(R)`` (the ``l = 1`` block is ``R`` permuted, see rotation.py)."""
    r1 = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            r1[i, j] = R[(i + 1) % 3, (j + 1) % 3]
    flat = np.zeros(offsets[-1])
    _rotation_blocks(r1, lmax, offsets, flat)
    return flat


@pjit
def _rotate_lighting(frames, L, lmax, offsets, out):
    """``out[p] = M(R_p) L`` (block-diagonal), for every pixel."""
    for p in numba.prange(frames.shape[0]):
        flat = _frame_blocks(frames[p], lmax, offsets)
        for l in range(lmax + 1):
            size = 2 * l + 1
            blk = flat[offsets[l] : offsets[l + 1]].reshape((size, size))
            base = l * l
            for i in range(size):
                for c in range(3):
                    acc = 0.0
                    for j in range(size):
                        acc += blk[i, j] * L[base + j, c]
                    out[p, base + i, c] = acc


@pjit
def _rotate_coeffs_to_world(frames, views, table, lmax, offsets, out):
    """``out[p] = M(R_p)ᵀ c(v_p)`` (the fixed-view precomputation)."""
    n = (lmax + 1) * (lmax + 1)
    for p in numba.prange(frames.shape[0]):
        flat = _frame_blocks(frames[p], lmax, offsets)
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
def _lookup_dot(views, table, L_local, out):
    """Steps 3–4 with pre-rotated lighting (fixed-light frame)."""
    n = table.shape[2]
    for p in numba.prange(views.shape[0]):
        c = np.empty((n, 3))
        fetch_into(table, views[p, 0], views[p, 1], views[p, 2], c)
        for ch in range(3):
            acc = 0.0
            for i in range(n):
                acc += L_local[p, i, ch] * c[i, ch]
            out[p, ch] = acc


@pjit
def _dot_world(coeffs_world, L, out):
    """The fixed-view frame: ``Q = Σ_i L_i (M(R_p)ᵀ c)_i``."""
    n = L.shape[0]
    for p in numba.prange(coeffs_world.shape[0]):
        for ch in range(3):
            acc = 0.0
            for i in range(n):
                acc += L[i, ch] * coeffs_world[p, i, ch]
            out[p, ch] = acc


def shading_frames(size: int):
    """World → local rotations ``(P, 3, 3)``, local views ``(P, 3)`` and the mask."""
    normals, tangents, mask = sphere_geometry(size)
    n, t = normals[mask], tangents[mask]
    b = np.cross(n, t)
    frames = np.stack([t, b, n], axis=1)
    views = frames @ np.array([0.0, 0.0, 1.0])
    views[:, 2] = np.maximum(views[:, 2], 0.0)
    return np.ascontiguousarray(frames), np.ascontiguousarray(views), mask


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


def render_kautz(env_asset, table, size: int = 192) -> tuple[np.ndarray, dict]:
    """Render the sphere; the image and per-mode (full, fixed_light, fixed_view) timings."""
    frames, views, mask = shading_frames(size)
    lmax = table.lmax
    L = lighting_with_sun(env_asset, lmax)
    coeffs = np.ascontiguousarray(table.coeffs)
    offsets = _block_offsets(lmax)
    P, n = len(frames), L.shape[0]
    L_local = np.empty((P, n, 3))
    c_world = np.empty((P, n, 3))
    q = np.empty((P, 3))

    def full():
        _rotate_lighting(frames, L, lmax, offsets, L_local)
        _lookup_dot(views, coeffs, L_local, q)

    def fixed_light():
        _lookup_dot(views, coeffs, L_local, q)

    def fixed_view():
        _dot_world(c_world, L, q)

    timing = {}
    _rotate_coeffs_to_world(frames, views, coeffs, lmax, offsets, c_world)
    for name, run in (("fixed_view", fixed_view), ("fixed_light", fixed_light), ("full", full)):
        run()  # compile / warm
        t0 = time.perf_counter()
        run()
        dt = time.perf_counter() - t0
        timing[name] = {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}
    img = np.zeros((size, size, 3))
    img[mask] = q
    return img, timing
