"""Brute-force Lambert irradiance over a solid-angle pyramid: the same sum, exactly, in a
fraction of the work.

The brute force (:mod:`shbake.reference.irradiance`) sums ``E(n) = Σ_p P_p max(0, n·ω_p)``
over every texel ``p`` (``P_p = L_p Ω_p``, per channel). For a group of texels that all lie
on the same side of ``n``'s horizon the clamp does nothing, so the group's sum is linear in
``n``: ``Σ_{p∈b} P_p max(0, n·ω_p) = max(0, n·m_b)`` with ``m_b = Σ_{p∈b} P_p ω_p`` — an
identity, not an approximation. The pyramid groups texels by direction into nested bins
(an equal-angle latitude–longitude grid of ``2^k × 2^(k+1)`` bins, level ``k``), each with
``m_b`` per channel and a bounding cone (centre ``c_b``, half-angle ``ρ_b`` over its texel
centres). A bin whose cone clears the horizon (``|n·c_b| > sin ρ_b``: every texel has
``n·ω_p`` of one sign) adds ``max(0, n·m_b)``; a bin the horizon crosses is opened (its four
children), down to the finest bins, whose texels are summed one by one as the brute force
does. The result is the brute-force sum reordered (equal to rounding, ~1e-13 relative:
``tests/reference/test_irradiance.py``); the work per query is proportional to the texels along the
horizon (≈ 4 % of them at 512 × 256) instead of all texels.

Only Lambert irradiance has this identity: Kajiya–Kay's ``sqrt(1 − (t·ω)²)`` is not linear
on any group, so tangent irradiance stays the texel-by-texel brute force.
"""

import functools

import numpy as np

from shbake.jit import jit, run_blocks

TOP_LEVEL = 3
"""Coarsest level of the pyramid: 8 × 16 bins."""
TEXELS_SIDE = 4.0
"""Texels along a side of a finest bin (of a lat-long map; 16 texels a bin): the horizon
test and the texel loop cost about the same there (measured at 512 × 256)."""
CONE_MARGIN = 1e-9
"""Added to ``sin ρ_b`` in the horizon test: a bin within this of the horizon is opened
(rounding in ``c_b`` and ``ρ_b`` never decides a clamp)."""


@jit
def _build_cones(dirs, finest_bin, level_offset, level_rows, centre, sin_radius):
    """Check-free: the bins' unit cone centres ``centre`` (bins, 3) and ``sin_radius`` (bins,):
    ``sin ρ_b``, −1 for an empty bin, 2 when ``ρ_b ≥ π/2`` (never cleared). ``finest_bin``
    (texels,): each texel's bin at the finest level (row-major, ``2 rows`` columns); levels
    as :func:`_query` takes them. A finest bin's cone holds its texels; a coarser bin's holds
    its four children's (``ρ ≤ max(∠(c, c_child) + ρ_child)``, conservative: a wider cone
    only opens the bin more often)."""
    n_levels = level_offset.shape[0]
    finest = level_offset[n_levels - 1]
    for p in range(dirs.shape[0]):
        for j in range(3):
            centre[finest + finest_bin[p], j] += dirs[p, j]
    radius = np.full(centre.shape[0], -1.0)
    for b in range(finest, centre.shape[0]):
        norm = np.sqrt(centre[b, 0] ** 2 + centre[b, 1] ** 2 + centre[b, 2] ** 2)
        if norm > 0.0:
            for j in range(3):
                centre[b, j] /= norm
    for p in range(dirs.shape[0]):
        b = finest + finest_bin[p]
        c = centre[b, 0] * dirs[p, 0] + centre[b, 1] * dirs[p, 1] + centre[b, 2] * dirs[p, 2]
        radius[b] = max(radius[b], np.arccos(min(1.0, max(-1.0, c))))
    for k in range(n_levels - 2, -1, -1):
        rows = level_rows[k]
        for b in range(level_offset[k], level_offset[k] + 2 * rows * rows):
            for kid in _children(b, k, level_offset, level_rows):
                if radius[kid] >= 0.0:
                    for m in range(3):
                        centre[b, m] += centre[kid, m]
            norm = np.sqrt(centre[b, 0] ** 2 + centre[b, 1] ** 2 + centre[b, 2] ** 2)
            if norm == 0.0:
                continue
            for m in range(3):
                centre[b, m] /= norm
            for kid in _children(b, k, level_offset, level_rows):
                if radius[kid] >= 0.0:
                    c = (centre[b, 0] * centre[kid, 0] + centre[b, 1] * centre[kid, 1]
                         + centre[b, 2] * centre[kid, 2])  # fmt: skip
                    radius[b] = max(radius[b], np.arccos(min(1.0, max(-1.0, c))) + radius[kid])
    for b in range(centre.shape[0]):
        if radius[b] < 0.0:
            sin_radius[b] = -1.0
        elif radius[b] >= 0.5 * np.pi:
            sin_radius[b] = 2.0
        else:
            sin_radius[b] = np.sin(radius[b])


@jit
def _children(b, k, level_offset, level_rows):
    """The four flat bin indices of level ``k + 1`` inside bin ``b`` of level ``k``."""
    rows = level_rows[k]
    i, j = divmod(b - level_offset[k], 2 * rows)
    first = level_offset[k + 1] + 2 * i * 4 * rows + 2 * j
    return (first, first + 1, first + 4 * rows, first + 4 * rows + 1)


@jit
def _build_sums(pixels, index, solid_angles, dirs, texel_start, level_offset, level_rows, lw,
                moment):  # fmt: skip
    """Check-free: ``lw[p, c] = pixels[index[p], c] Ω_p`` (float64) of each texel ``p`` in
    bin order (``pixels`` flat ``(texels, 3)``, the map's own order), and ``moment[b, c] =
    Σ_{p∈b} lw[p, c] dirs[p]`` (bins, 3 channels, 3) over the finest bins' texels, then each
    coarser bin the sum of its four children."""
    n_levels = level_offset.shape[0]
    finest = level_offset[n_levels - 1]
    for f in range(texel_start.shape[0] - 1):
        for p in range(texel_start[f], texel_start[f + 1]):
            for c in range(3):
                lw[p, c] = np.float64(pixels[index[p], c]) * solid_angles[p]
                for j in range(3):
                    moment[finest + f, c, j] += lw[p, c] * dirs[p, j]
    for k in range(n_levels - 2, -1, -1):
        for b in range(level_offset[k], level_offset[k] + 2 * level_rows[k] * level_rows[k]):
            for kid in _children(b, k, level_offset, level_rows):
                for c in range(3):
                    for j in range(3):
                        moment[b, c, j] += moment[kid, c, j]


@jit
def _query(moment, centre, sin_radius, level_offset, level_rows, texel_start, dirs, lw,
           queries, out, b0, b1):  # fmt: skip
    """Check-free: Lambert irradiance ``out[q]`` (3 channels) at unit ``queries[q]`` for
    ``q ∈ [b0, b1)`` (module docstring); ``level_offset[k]`` the first flat bin of level
    ``TOP_LEVEL + k`` (rows ``level_rows[k]``, columns twice that);
    ``dirs`` and ``lw`` the texels sorted by finest bin, ``texel_start`` (finest bins + 1,)
    each finest bin's first."""
    n_levels = level_offset.shape[0]
    top_rows = level_rows[0]
    depth = 2 * top_rows * top_rows + 4 * n_levels  # the top bins, then 3 more per level
    stack_level = np.empty(depth, np.int64)
    stack_row = np.empty(depth, np.int64)
    stack_col = np.empty(depth, np.int64)
    finest = n_levels - 1
    for q in range(b0, b1):
        qx, qy, qz = queries[q, 0], queries[q, 1], queries[q, 2]
        r = 0.0
        g = 0.0
        bl = 0.0
        top = 0
        for i in range(top_rows):
            for j in range(2 * top_rows):
                stack_level[top] = 0
                stack_row[top] = i
                stack_col[top] = j
                top += 1
        while top > 0:
            top -= 1
            k, i, j = stack_level[top], stack_row[top], stack_col[top]
            b = level_offset[k] + i * 2 * level_rows[k] + j
            s = sin_radius[b]
            if s < 0.0:
                continue  # no texel in this bin
            d = qx * centre[b, 0] + qy * centre[b, 1] + qz * centre[b, 2]
            if d > s + CONE_MARGIN:  # every texel above the horizon: linear
                r += qx * moment[b, 0, 0] + qy * moment[b, 0, 1] + qz * moment[b, 0, 2]
                g += qx * moment[b, 1, 0] + qy * moment[b, 1, 1] + qz * moment[b, 1, 2]
                bl += qx * moment[b, 2, 0] + qy * moment[b, 2, 1] + qz * moment[b, 2, 2]
            elif d < -s - CONE_MARGIN:
                continue  # every texel below: nothing
            elif k == finest:
                f = b - level_offset[finest]
                for p in range(texel_start[f], texel_start[f + 1]):
                    c = max(0.0, qx * dirs[p, 0] + qy * dirs[p, 1] + qz * dirs[p, 2])
                    r += c * lw[p, 0]
                    g += c * lw[p, 1]
                    bl += c * lw[p, 2]
            else:
                for di in range(2):
                    for dj in range(2):
                        stack_level[top] = k + 1
                        stack_row[top] = 2 * i + di
                        stack_col[top] = 2 * j + dj
                        top += 1
        out[q, 0] = r
        out[q, 1] = g
        out[q, 2] = bl


class PyramidGeometry:
    """The bins of one texel layout and shape: the pyramid's part that no radiance changes
    (texel directions and solid angles, bins, cones, texels sorted by finest bin), built
    once per layout and shape (:func:`pyramid_geometry`)."""

    def __init__(self, layout: str, shape: tuple[int, int]):
        from shbake.envmap.layouts import texels

        dirs, omega, mask = texels(layout, *shape)
        self.dirs = np.ascontiguousarray(dirs[mask], dtype=np.float64)
        self.solid_angles = np.asarray(omega[mask], dtype=np.float64)
        n = max(self.dirs.shape[0], 1)
        # finest bins hold about TEXELS_SIDE² texels of an equal-angle map
        finest = max(TOP_LEVEL, int(np.floor(np.log2(max(np.sqrt(n / 2.0) / TEXELS_SIDE, 1.0)))))
        rows = 2 ** np.arange(TOP_LEVEL, finest + 1)
        theta = np.arccos(np.clip(self.dirs[:, 2], -1.0, 1.0))
        phi = np.mod(np.arctan2(self.dirs[:, 1], self.dirs[:, 0]), 2 * np.pi)
        h = int(rows[-1])
        i = np.minimum((theta * (h / np.pi)).astype(np.int64), h - 1)
        finest_bin = i * 2 * h + np.minimum((phi * (h / np.pi)).astype(np.int64), 2 * h - 1)
        offsets = np.concatenate([[0], np.cumsum(2 * rows * rows)])
        self.level_offset = offsets[:-1].astype(np.int64)
        self.level_rows = rows.astype(np.int64)
        self.bins = int(offsets[-1])
        self.centre = np.zeros((self.bins, 3))
        self.sin_radius = np.zeros(self.bins)
        _build_cones(self.dirs, finest_bin, self.level_offset, self.level_rows, self.centre,
                     self.sin_radius)  # fmt: skip
        order = np.argsort(finest_bin, kind="stable")  # texels by finest bin, contiguous
        self.texel_start = np.searchsorted(finest_bin[order], np.arange(2 * h * h + 1))
        self.dirs = np.ascontiguousarray(self.dirs[order])
        self.solid_angles = self.solid_angles[order]
        self.index = np.flatnonzero(mask.ravel())[order]  # each sorted texel in the map


@functools.lru_cache(maxsize=4)
def pyramid_geometry(layout: str, shape: tuple[int, int]) -> PyramidGeometry:
    """:class:`PyramidGeometry` of ``layout`` and ``shape``, once per process."""
    return PyramidGeometry(layout, shape)


class IrradiancePyramid:
    """The pyramid of one map (module docstring); :meth:`irradiance` at any normals.

    ``env``: an :class:`~shbake.envmap.environment.Environment` (its texel geometry from
    :func:`pyramid_geometry`, its radiance summed here in O(texels)).
    """

    def __init__(self, env):
        self.geometry = g = pyramid_geometry(env.layout, env.shape)
        flat = env.pixels.reshape(-1, env.pixels.shape[-1])
        self.lw = np.empty((g.dirs.shape[0], 3))  # texels' L Ω in bin order (float64)
        self.moment = np.zeros((g.bins, 3, 3))
        _build_sums(flat, g.index, g.solid_angles, g.dirs, g.texel_start, g.level_offset,
                    g.level_rows, self.lw, self.moment)  # fmt: skip

    def irradiance(self, normals) -> np.ndarray:
        """Lambert irradiance ``(..., 3)`` at unit ``normals (..., 3)``: the brute-force sum."""
        g = self.geometry
        q = np.asarray(normals, dtype=np.float64)
        flat = np.ascontiguousarray(q.reshape(-1, 3))
        out = np.empty((flat.shape[0], 3))
        work = flat.shape[0] * (g.bins * 0.1 + g.dirs.shape[0] * 0.05) * 10.0
        run_blocks(_query, flat.shape[0], work, self.moment, g.centre, g.sin_radius,
                   g.level_offset, g.level_rows, g.texel_start, g.dirs, self.lw, flat,
                   out)  # fmt: skip
        return out.reshape(q.shape[:-1] + (3,))
