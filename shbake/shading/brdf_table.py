"""Kautz et al. 2002 §4 shading of a BRDF table under SH lighting: rotate, fetch, dot.

Per shading point with world → local frame ``R`` (rows: tangent, bitangent,
normal) and local view ``v``:

1. rotate the lighting coefficients into the local frame, ``L_p = M(R) L``;
2. (the caller rotates the view vector, ``v_p = R v``);
3. fetch ``c(v_p)`` from the parabolic table, bilinearly;
4. ``Q = Σ_i L_p,i c_i(v_p)`` per channel.

A full frame (light and view both changing) runs steps 1–4 fused per block
of pixels (:func:`shade_full`: the blocks of ``M(R_p)`` built together,
vectorised across the block, ``L_p`` never stored). Fixed light: ``L_p`` is
computed once, a frame costs steps 2–4. Fixed view:
``M(R)ᵀ c(v_p)`` is computed once, a frame (a lighting change) costs one dot
product per point. A sun extracted into the environment asset is added to
``L`` as the SH projection of a directional light, ``E_sun y_i(s)``,
band-limited like the rest.
"""

import numpy as np

from shbake.brdf.sampling import fibre_frames
from shbake.conventions import lmax_of
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.rotation import (
    block_offsets,
    p_rows,
    rotation_blocks_many,
    rotation_coefficients,
)
from shbake.shading.env_sh import lights_of
from shbake.shading.shader import Shader, Texture
from shbake.shading.sphere_light import lights_sh
from shbake.texture.parabolic import fetch_flat_into, fetch_into

PIXEL_BLOCK = 64
"""Pixels per block of the per-pixel rotations: their blocks of ``M(R_p)`` are built
together, vectorised across the block (:func:`~shbake.sh.rotation.rotation_blocks_many`),
in scratch allocated once per range of blocks."""


@jit
def _block_frames(frames, lmax, offsets, uvw, p0, nb, r1, pbuf, flat):
    """``flat[:, k]`` = blocks of ``M(R_{p0+k})``, ``k < nb`` (the ``l = 1`` blocks are ``R``
    permuted, rotation.py)."""
    for i in range(3):
        for j in range(3):
            for k in range(nb):
                r1[i, j, k] = frames[p0 + k, (i + 1) % 3, (j + 1) % 3]
    rotation_blocks_many(r1, lmax, offsets, uvw, pbuf, flat, nb)


@jit
def _apply_blocks(flat, L, lmax, offsets, nb, acc):
    """``acc[:, :, k] = M(R_k) L`` from the blocks ``flat[:, k]``, ``k < nb`` (vectorised across
    the pixels; each entry summed over ``j`` ascending from 0.0)."""
    for l in range(lmax + 1):
        size = 2 * l + 1
        o = offsets[l]
        base = l * l
        for i in range(size):
            r = base + i
            for k in range(nb):
                acc[r, 0, k] = 0.0
                acc[r, 1, k] = 0.0
                acc[r, 2, k] = 0.0
            for j in range(size):
                e = o + i * size + j
                l0 = L[base + j, 0]
                l1 = L[base + j, 1]
                l2 = L[base + j, 2]
                for k in range(nb):
                    f = flat[e, k]
                    acc[r, 0, k] += f * l0
                    acc[r, 1, k] += f * l1
                    acc[r, 2, k] += f * l2


@jit
def _rotate_lighting_blocks(frames, L, lmax, offsets, uvw, out, b0, b1):
    n_pix = frames.shape[0]
    bs = PIXEL_BLOCK
    r1 = np.empty((3, 3, bs))
    pbuf = np.empty((p_rows(lmax), bs))
    flat = np.empty((offsets[-1], bs))
    n = L.shape[0]
    acc = np.empty((n, 3, bs))
    for blk in range(b0, b1):
        p0 = blk * bs
        nb = min(bs, n_pix - p0)
        _block_frames(frames, lmax, offsets, uvw, p0, nb, r1, pbuf, flat)
        _apply_blocks(flat, L, lmax, offsets, nb, acc)
        for k in range(nb):
            for i in range(n):
                out[p0 + k, i, 0] = acc[i, 0, k]
                out[p0 + k, i, 1] = acc[i, 1, k]
                out[p0 + k, i, 2] = acc[i, 2, k]


def _blocks(n_pix: int) -> int:
    return -(-n_pix // PIXEL_BLOCK)


def rotate_lighting(frames, L, lmax, offsets, out):
    """``out[p] = M(R_p) L`` (block-diagonal), for every pixel (step 1).

    The recurrence's ``u, v, w`` factors are computed once per call; pixels go
    in blocks of :data:`PIXEL_BLOCK` whose rotation blocks are built together
    (vectorised across the pixels) in scratch allocated once per range of
    blocks, then applied to ``L``; :func:`shbake.jit.run_blocks` runs the ranges.
    Check-free: ``frames (P, 3, 3)``, ``L (n, 3)``, ``out (P, n, 3)`` float64
    C-contiguous, ``offsets`` from :func:`~shbake.sh.rotation.block_offsets`.
    """
    uvw = np.empty(3 * int(offsets[-1]))
    rotation_coefficients(lmax, offsets, uvw)
    n_pix = frames.shape[0]
    run_blocks(_rotate_lighting_blocks, _blocks(n_pix), n_pix * 12.0 * offsets[-1],
               frames, L, lmax, offsets, uvw, out)  # fmt: skip


@jit
def _to_world_blocks(frames, views, table, lmax, offsets, uvw, out, b0, b1):
    n_pix = frames.shape[0]
    n = (lmax + 1) * (lmax + 1)
    bs = PIXEL_BLOCK
    r1 = np.empty((3, 3, bs))
    pbuf = np.empty((p_rows(lmax), bs))
    flat = np.empty((offsets[-1], bs))
    c = np.empty((n, 3))
    cb = np.empty((n, 3, bs))
    for blk in range(b0, b1):
        p0 = blk * bs
        nb = min(bs, n_pix - p0)
        _block_frames(frames, lmax, offsets, uvw, p0, nb, r1, pbuf, flat)
        for k in range(nb):
            p = p0 + k
            fetch_into(table, views[p, 0], views[p, 1], views[p, 2], c)
            for i in range(n):
                for ch in range(3):
                    cb[i, ch, k] = c[i, ch]
        for l in range(lmax + 1):
            size = 2 * l + 1
            o = offsets[l]
            base = l * l
            for j in range(size):
                for ch in range(3):
                    for k in range(nb):
                        acc = 0.0
                        for i in range(size):
                            acc += flat[o + i * size + j, k] * cb[base + i, ch, k]
                        out[p0 + k, base + j, ch] = acc


def rotate_coeffs_to_world(frames, views, table, lmax, offsets, out):
    """``out[p] = M(R_p)ᵀ c(v_p)`` (the fixed-view precomputation; blocked as
    :func:`rotate_lighting`). Check-free."""
    uvw = np.empty(3 * int(offsets[-1]))
    rotation_coefficients(lmax, offsets, uvw)
    n_pix = frames.shape[0]
    run_blocks(_to_world_blocks, _blocks(n_pix), n_pix * 12.0 * offsets[-1],
               frames, views, table, lmax, offsets, uvw, out)  # fmt: skip


@jit
def _dot3(Lp, c):
    """``Σ_i Lp[i, ch] c[3i + ch]`` per channel, ``i`` ascending (three chains interleaved)."""
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    for i in range(Lp.shape[0]):
        a0 += Lp[i, 0] * c[3 * i]
        a1 += Lp[i, 1] * c[3 * i + 1]
        a2 += Lp[i, 2] * c[3 * i + 2]
    return a0, a1, a2


@jit
def _lookup_dot_blocks(views, table, L_local, out, b0, b1):
    c = np.empty(table.shape[2])
    for p in range(b0 * PIXEL_BLOCK, min(views.shape[0], b1 * PIXEL_BLOCK)):
        fetch_flat_into(table, views[p, 0], views[p, 1], views[p, 2], c)
        out[p, 0], out[p, 1], out[p, 2] = _dot3(L_local[p], c)


@jit
def _shade_full_blocks(frames, views, table, L, lmax, offsets, uvw, out, b0, b1):
    n_pix = frames.shape[0]
    n = (lmax + 1) * (lmax + 1)
    bs = PIXEL_BLOCK
    r1 = np.empty((3, 3, bs))
    pbuf = np.empty((p_rows(lmax), bs))
    flat = np.empty((offsets[-1], bs))
    acc = np.empty((n, 3, bs))
    c = np.empty(table.shape[2])
    for blk in range(b0, b1):
        p0 = blk * bs
        nb = min(bs, n_pix - p0)
        _block_frames(frames, lmax, offsets, uvw, p0, nb, r1, pbuf, flat)
        _apply_blocks(flat, L, lmax, offsets, nb, acc)
        for k in range(nb):
            p = p0 + k
            fetch_flat_into(table, views[p, 0], views[p, 1], views[p, 2], c)
            out[p, 0], out[p, 1], out[p, 2] = _dot3(acc[:, :, k], c)


def shade_full(frames, views, table, L, lmax, offsets, out):
    """Steps 1–4 fused, one frame with both light and view changing: ``out[p] = Σ_i
    (M(R_p) L)_i c_i(v_p)``, the same values and summation order as
    :func:`rotate_lighting` then :func:`lookup_dot`, without storing ``M(R_p) L``.

    Rotation blocks built per pixel block (:data:`PIXEL_BLOCK`, vectorised
    across it) in scratch allocated once per range of blocks. Check-free.
    """
    uvw = np.empty(3 * int(offsets[-1]))
    rotation_coefficients(lmax, offsets, uvw)
    n_pix = frames.shape[0]
    flat = table.reshape(table.shape[0], table.shape[1], -1)
    run_blocks(_shade_full_blocks, _blocks(n_pix), n_pix * 16.0 * offsets[-1],
               frames, views, flat, L, lmax, offsets, uvw, out)  # fmt: skip


def lookup_dot(views, table, L_local, out):
    """Steps 3–4 with pre-rotated lighting (fixed-light frame): the bilinear fetch of
    :func:`~shbake.texture.parabolic.fetch_into` fused with the dot product (nothing
    allocated per pixel). Check-free."""
    n_pix = views.shape[0]
    flat = table.reshape(table.shape[0], table.shape[1], -1)
    run_blocks(_lookup_dot_blocks, _blocks(n_pix), n_pix * 10.0 * flat.shape[2],
               views, flat, L_local, out)  # fmt: skip


@jit
def _dot_world_blocks(coeffs_world, L, out, b0, b1):
    n = L.shape[0]
    for p in range(b0 * PIXEL_BLOCK, min(coeffs_world.shape[0], b1 * PIXEL_BLOCK)):
        for ch in range(3):
            acc = 0.0
            for i in range(n):
                acc += L[i, ch] * coeffs_world[p, i, ch]
            out[p, ch] = acc


def dot_world(coeffs_world, L, out):
    """The fixed-view frame: ``Q = Σ_i L_i (M(R_p)ᵀ c)_i``. Check-free."""
    n_pix = coeffs_world.shape[0]
    run_blocks(_dot_world_blocks, _blocks(n_pix), n_pix * 6.0 * L.shape[0],
               coeffs_world, L, out)  # fmt: skip


def lighting_with_sun(env_asset, lmax: int) -> np.ndarray:
    """``(n, 3)`` world lighting coefficients of an ``env_sh`` asset, its lights (sun or
    fitted) folded in as SH of delta lights (sphere lights: of their energy, band ``l``
    times the cap's :func:`~shbake.shading.sphere_light.cap_band_factors`, exact)."""
    L = np.asarray(env_asset["/lighting/sh"], dtype=float)
    n = (lmax + 1) ** 2
    if L.shape[0] < n:
        have = lmax_of(L.shape[0])
        raise ParameterError(
            f"the environment asset has lighting to lmax {have}; the table needs {lmax}"
        )
    L = L[:n].copy()
    dirs, energy, radii = lights_of(env_asset)
    if len(dirs):
        L += lights_sh(dirs, energy, radii, lmax)
    return np.ascontiguousarray(L)


class KautzShader(Shader):
    """A BRDF table (Kautz et al. 2002) under an ``env_sh`` asset's lighting, lights folded in
    (:func:`lighting_with_sun`): per point the local frame of :func:`~shbake.brdf.sampling.
    fibre_frames` (normal, brushing ``tangents``), the view in it (``z`` clamped to 0),
    steps 1–4 of the module docstring. ``from_asset(env_asset, table=BRDFTable)``
    (:func:`shbake.format.brdf_table.table_at`)."""

    name = "kautz"
    glsl = "kautz.glsl:shbakeKautz"
    kinds = ("env_sh", "brdf_table")
    inputs = (
        Texture("lighting_sh", "sh-vector", ("(lmax+1)**2", 3),
                "/lighting/sh + /sun/direction + /sun/radiance × /sun/solid_angle + "
                "/lights/direction + /lights/irradiance + /lights/angular_radius",
                "radiance SH L_lm of the env_sh asset to the table's lmax, each light (the sun "
                "or the fitted ones) added as E_k y_i(s_k), a sphere as its cap's SH"),
        Texture("brdf_table", "parabolic", ("*lead", "H", "W", "(lmax+1)**2"),
                "brdf_table: /table", "c_i(v) = ∫ y_i(s) f(s, v) max(0, s_z) ds over the view "
                "hemisphere; lead: RGB channels and varied parameters (one point is shaded)"),
    )  # fmt: skip
    truth = "brdf"
    tangents = True

    def __init__(self, lighting, table):
        self.table = table
        self.lmax = table.lmax
        self.lighting = lighting
        self.coeffs = np.ascontiguousarray(table.coeffs)
        self.offsets = block_offsets(self.lmax)
        self.point_coeffs = self.coeffs.shape[-2]  # the rotated lighting and table of modes()

    @classmethod
    def from_asset(cls, asset, table=None, **companions):
        if table is None:
            raise ParameterError("kautz shading needs a BRDF table (--table TABLE.h5)")
        return cls(lighting_with_sun(asset, table.lmax), table)

    def frames(self, normals, views, tangents):
        """World → local frames ``(N, 3, 3)`` and local views ``(N, 3)`` (``z ≥ 0``)."""
        frames = fibre_frames(normals, tangents)
        local = np.einsum("pij,pj->pi", frames, np.broadcast_to(views, frames.shape[:2]))
        local[:, 2] = np.maximum(local[:, 2], 0.0)
        return frames, np.ascontiguousarray(local)

    def shade(self, normals, views, tangents=None):
        frames, local = self.frames(normals, views, tangents)
        out = np.empty((len(frames), 3))
        shade_full(frames, local, self.coeffs, self.lighting, self.lmax, self.offsets, out)
        return out

    def modes(self, normals, views, tangents=None):
        """``full`` (light and view change: :meth:`shade`), ``fixed_light`` (the rotated
        lighting precomputed) and ``fixed_view`` (the table rotated to the world
        precomputed); the precomputations are not part of a frame."""
        frames, local = self.frames(normals, views, tangents)
        n_pix, n = len(frames), self.lighting.shape[0]
        lit, world = np.empty((n_pix, n, 3)), np.empty((n_pix, n, 3))
        rotate_lighting(frames, self.lighting, self.lmax, self.offsets, lit)
        rotate_coeffs_to_world(frames, local, self.coeffs, self.lmax, self.offsets, world)

        def fixed_light():
            out = np.empty((n_pix, 3))
            lookup_dot(local, self.coeffs, lit, out)
            return out

        def fixed_view():
            out = np.empty((n_pix, 3))
            dot_world(world, self.lighting, out)
            return out

        full = {"full": lambda: self.shade(normals, views, tangents)}
        return full | {"fixed_light": fixed_light, "fixed_view": fixed_view}

    def label(self) -> str:
        return f"table {self.table.model} lmax {self.lmax}"
