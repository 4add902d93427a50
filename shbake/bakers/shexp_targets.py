"""The SH-exp fit's ``E0`` targets by filtered importance sampling (a map-independent plan).

The fit needs ``E0`` (:mod:`shbake.reference.ggx`) at a fixed set of
``(v, n, r)`` targets for every probe. Everything that does not depend on the
map — the visible-normal sample directions, the pyramid texels they read and
their weights — is built once per (targets, samples, map shape) as a
:class:`QuadraturePlan`; a probe is then one pyramid build and one gather.

Filtered importance sampling (Křivánek & Colbert 2008): each of the
``samples`` visible-normal samples reads the level of the map's solid-angle
pyramid (:mod:`shbake.envmap.importance`) whose texels match its share of the
sphere, so a broad lobe reads a coarse level. A map's brightest texels (a sun,
lamps), whose few samples would make every target noisy, are taken out of the
pyramid and added exactly as point lights at their centres.
"""

from dataclasses import dataclass

import numba
import numpy as np

from shbake.brdf.ggx import check_geometry, sample_light, vndf_terms
from shbake.brdf.sampling import surface_frame
from shbake.conventions import check_samples, ggx_alpha
from shbake.envmap.importance import (
    bright_texels,
    latlong_flat,
    latlong_pyramid,
    level_offsets,
    pyramid_levels,
)
from shbake.envmap.layouts import latlong_texel, row_solid_angle
from shbake.errors import ParameterError
from shbake.jit import jit, pjit
from shbake.sh.point_sets import fibonacci_square

LOD_BIAS = 1.0
"""Pyramid levels one coarser than the sample footprint (Křivánek & Colbert 2008)."""


@pjit
def _add_point_lights(views, normals, alphas, dirs, energy, out):
    """``out += Σ_k f_DV(v, n, l_k) (n·l_k) E_k`` (:func:`vndf_terms`: ``p(l) G1(l)``)."""
    for t in numba.prange(views.shape[0]):
        nx, ny, nz = normals[t, 0], normals[t, 1], normals[t, 2]
        (tx, ty, tz), (bx, by, bz), (v0, v1, v2) = surface_frame(
            views[t, 0], views[t, 1], views[t, 2], nx, ny, nz
        )
        for k in range(dirs.shape[0]):
            lx, ly, lz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
            l2 = nx * lx + ny * ly + nz * lz
            if l2 <= 0.0:
                continue
            l0, l1 = tx * lx + ty * ly + tz * lz, bx * lx + by * ly + bz * lz
            pdf, g1l, _ = vndf_terms(v0, v1, v2, l0, l1, l2, alphas[t])
            w = pdf * g1l
            for c in range(3):
                out[t, c] += w * energy[k, c]


@jit
def _filtered_texel(lx, ly, lz, pdf, n, height, width, levels, offsets, log2_omega):
    """Pyramid texel (flat, across levels) for a sample of density ``pdf`` among ``n``.

    Level ``k = ⌊½ log2(Ω_s / Ω_texel) + 1⌋`` clamped to ``[0, levels − 1]``, where
    ``Ω_s = 1/(n p)`` is the sample's share of the sphere and ``Ω_texel`` the
    level-0 texel it lands in (Křivánek & Colbert 2008); ``log2_omega[row]``
    is ``log2 Ω_texel`` per row.
    """
    j = latlong_texel(lx, ly, lz, height, width)
    row, col = j // width, j % width
    lod = -0.5 * (np.log2(n * pdf) + log2_omega[row])
    k = min(max(int(np.floor(lod + LOD_BIAS)), 0), levels - 1)
    return offsets[k] + (row >> k) * (width >> k) + (col >> k)


@pjit
def _plan_rows(views, normals, alphas, square, height, width, offsets, index, weight, count):
    n = square.shape[0]
    levels = offsets.shape[0] - 1
    log2_omega = np.empty(height)
    for row in range(height):
        log2_omega[row] = np.log2(row_solid_angle(row, height, width))
    for t in numba.prange(views.shape[0]):
        prm = np.zeros(6)
        prm[3] = prm[4] = alphas[t]
        nrm = (normals[t, 0], normals[t, 1], normals[t, 2])
        tan, bit, v_loc = surface_frame(views[t, 0], views[t, 1], views[t, 2], *nrm)
        for k in range(n):
            lx, ly, lz, w0, _, pdf = sample_light(
                tan, bit, nrm, v_loc, alphas[t], prm, square[k, 0], square[k, 1]
            )
            if w0 > 0.0:
                index[t, k] = _filtered_texel(
                    lx, ly, lz, pdf, n, height, width, levels, offsets, log2_omega
                )
            else:
                index[t, k] = 0
            weight[t, k] = w0 / n
        # memory order, then one entry per texel
        order = np.argsort(index[t])
        idx = index[t][order]
        wgt = weight[t][order]
        m = 0
        for k in range(n):
            if wgt[k] == 0.0:
                continue
            if m > 0 and idx[k] == index[t, m - 1]:
                weight[t, m - 1] += wgt[k]
            else:
                index[t, m] = idx[k]
                weight[t, m] = wgt[k]
                m += 1
        count[t] = m


@pjit
def _compact(index, weight, offsets, flat_index, flat_weight):
    for t in numba.prange(index.shape[0]):
        a = offsets[t]
        for k in range(offsets[t + 1] - a):
            flat_index[a + k] = index[t, k]
            flat_weight[a + k] = weight[t, k]


@pjit
def _gather(offsets, index, weight, pixels, out):
    for t in numba.prange(offsets.shape[0] - 1):
        a0 = a1 = a2 = 0.0
        for k in range(offsets[t], offsets[t + 1]):
            j = index[k]
            w = weight[k]
            a0 += w * pixels[j, 0]
            a1 += w * pixels[j, 1]
            a2 += w * pixels[j, 2]
        out[t, 0], out[t, 1], out[t, 2] = a0, a1, a2


@dataclass
class QuadraturePlan:
    """Texels and weights of ``E0`` at fixed ``(v, n, r)`` targets for one map shape.

    Rows are stored back to back (``offsets``, ``index`` into the stacked
    pyramid, ``weight``), each sorted by texel, samples landing in one texel
    merged (module docstring).
    """

    shape: tuple[int, int]
    levels: int
    offsets: np.ndarray
    index: np.ndarray
    weight: np.ndarray
    views: np.ndarray
    normals: np.ndarray
    alphas: np.ndarray

    @classmethod
    def build(cls, views, normals, roughness, samples: int, shape: tuple[int, int]):
        v, n, r = check_geometry(views, normals, roughness)
        samples = check_samples(samples)
        levels = pyramid_levels(shape)
        index = np.empty((v.shape[0], samples), dtype=np.int32)
        weight = np.empty((v.shape[0], samples), dtype=np.float32)
        count = np.empty(v.shape[0], dtype=np.int64)
        square = fibonacci_square(samples)
        starts = level_offsets(shape, levels)
        _plan_rows(v, n, ggx_alpha(r), square, shape[0], shape[1], starts, index, weight, count)
        offsets = np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
        flat_index = np.empty(offsets[-1], dtype=np.int32)
        flat_weight = np.empty(offsets[-1], dtype=np.float32)
        _compact(index, weight, offsets, flat_index, flat_weight)
        return cls(tuple(shape), levels, offsets, flat_index, flat_weight, v, n, ggx_alpha(r))

    def e0(self, pixels) -> np.ndarray:
        """``E0`` at the plan's targets, ``(T, 3)`` float64."""
        flat, h, w = latlong_flat(pixels)
        if (h, w) != self.shape:
            raise ParameterError(f"plan is for {self.shape[1]}x{self.shape[0]} maps, got {w}x{h}")
        lights, dirs, energy = bright_texels(flat, h, w)
        if lights.size:
            flat = flat.copy()
            flat[lights] = 0.0
        pyramid = latlong_pyramid(flat, self.shape, self.levels)
        out = np.empty((self.offsets.shape[0] - 1, 3))
        _gather(self.offsets, self.index, self.weight, pyramid, out)
        if lights.size:
            _add_point_lights(self.views, self.normals, self.alphas, dirs, energy, out)
        return out
