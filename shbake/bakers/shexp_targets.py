"""The SH-exp fit's ``E0`` targets by filtered importance sampling (a map-independent plan).

The fit needs ``E0`` (:mod:`shbake.reference.ggx`) at a fixed set of
``(v, n, α)`` targets for every probe. Everything that does not depend on the
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

import functools
from dataclasses import dataclass

import numpy as np

from shbake.brdf.ggx import (
    check_geometry,
    ggx_d,
    sample_light_at,
    smith_lambda,
    view_g1,
    vndf_frame,
)
from shbake.brdf.sampling import surface_frame
from shbake.conventions import check_samples
from shbake.envmap.importance import (
    bright_texels,
    latlong_flat,
    latlong_pyramid,
    level_offsets,
    pyramid_levels,
)
from shbake.envmap.layouts import latlong_texel, log2_row_solid_angles
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.reference.ggx import check_alpha
from shbake.sh.point_sets import fibonacci_square

LOD_BIAS = 1.0
"""Pyramid levels one coarser than the sample footprint (Křivánek & Colbert 2008)."""


@jit
def _add_point_lights(views, normals, alphas, dirs, energy, order, group_start, out, b0, b1):
    """``out += Σ_k f_DV(v, n, l_k) (n·l_k) E_k = Σ_k G1(v) D(h) G1(l) / (4 n·v) E_k``.

    Isotropic GGX needs only ``n·h`` and ``n·l``, so no tangent frame is built: ``D`` and
    ``Λ`` (:mod:`shbake.brdf.ggx`) get the equivalent local vectors ``(sin θ, 0, cos θ)``,
    and ``G1(v)/(4 n·v)`` is hoisted out of the light loop. Targets come in groups of one
    ``(v, n)`` (:func:`pair_groups`: ``order[group_start[g]:group_start[g + 1]]``, groups of
    one normal in a row; blocks ``[b0, b1)`` are groups): the lights above ``n``'s horizon
    and their ``n·l`` are found once per normal, ``n·h`` and ``sin θh`` once per group, and
    ``G1(l)`` once per normal and ``α`` (kept while a group's ``α`` repeat the previous
    group's); each target sums its visible lights in light order, as the plain loop does.
    """
    n_lights = dirs.shape[0]
    seen = np.empty(n_lights, np.int64)  # visible lights of the current normal, in order
    seen_nl = np.empty(n_lights)
    seen_nh = np.empty(n_lights)
    seen_sin_h = np.empty(n_lights)
    most = 0
    for g in range(b0, b1):
        most = max(most, group_start[g + 1] - group_start[g])
    g1l = np.empty((most, n_lights))  # G1(l) of the group's i-th α
    g1l_alpha = np.full(most, np.nan)  # the α each row holds (NaN: none; equals nothing)
    n_seen = 0
    last_n = np.full(3, np.nan)
    for g in range(b0, b1):
        first = order[group_start[g]]
        vx, vy, vz = views[first, 0], views[first, 1], views[first, 2]
        nx, ny, nz = normals[first, 0], normals[first, 1], normals[first, 2]
        if not (nx == last_n[0] and ny == last_n[1] and nz == last_n[2]):
            last_n[0], last_n[1], last_n[2] = nx, ny, nz
            g1l_alpha[:] = np.nan
            n_seen = 0
            for k in range(n_lights):
                nl = nx * dirs[k, 0] + ny * dirs[k, 1] + nz * dirs[k, 2]
                if nl > 0.0:
                    seen[n_seen] = k
                    seen_nl[n_seen] = nl
                    n_seen += 1
        nv = nx * vx + ny * vy + nz * vz
        for i in range(n_seen):
            k = seen[i]
            hn = np.sqrt(max(2.0 + 2.0 * (vx * dirs[k, 0] + vy * dirs[k, 1] + vz * dirs[k, 2]),
                             1e-300))  # fmt: skip
            nh = min(1.0, (nv + seen_nl[i]) / hn)
            seen_nh[i] = nh
            seen_sin_h[i] = np.sqrt(max(0.0, 1.0 - nh * nh))
        for slot in range(group_start[g + 1] - group_start[g]):
            t = order[group_start[g] + slot]
            a = alphas[t]
            if not a == g1l_alpha[slot]:
                g1l_alpha[slot] = a
                for i in range(n_seen):
                    nl = seen_nl[i]
                    g1l[slot, i] = 1.0 / (
                        1.0 + smith_lambda(a, a, np.sqrt(max(0.0, 1.0 - nl * nl)), 0.0, nl)
                    )
            front = 1.0 / ((1.0 + smith_lambda(a, a, np.sqrt(max(0.0, 1.0 - nv * nv)), 0.0,
                                               nv)) * 4.0 * nv)  # fmt: skip
            for i in range(n_seen):
                k = seen[i]
                w = front * ggx_d(a, a, seen_sin_h[i], 0.0, seen_nh[i]) * g1l[slot, i]
                for c in range(3):
                    out[t, c] += w * energy[k, c]


def pair_groups(views, normals):
    """Targets grouped by ``(v, n)``: ``(order, group_start)``, ``order`` the targets sorted
    by normal, then view (stable), and group ``g`` ``order[group_start[g]:group_start[g+1]]``
    (its targets differ in ``α`` only) — what :func:`_add_point_lights` walks."""
    keys = np.concatenate([normals, views], axis=1)
    order = np.lexsort(keys.T[::-1])
    ordered = keys[order]
    change = np.flatnonzero(np.any(ordered[1:] != ordered[:-1], axis=1)) + 1
    return order, np.concatenate([[0], change, [keys.shape[0]]]).astype(np.int64)


@jit
def filtered_texel(lx, ly, lz, pdf, n, height, width, levels, offsets, log2_omega):
    """Pyramid texel (flat, across levels) for a sample of density ``pdf`` among ``n``.

    Level ``k = ⌊½ log2(Ω_s / Ω_texel) + 1⌋`` clamped to ``[0, levels − 1]``, where
    ``Ω_s = 1/(n p)`` is the sample's share of the sphere and ``Ω_texel`` the
    level-0 texel it lands in (Křivánek & Colbert 2008); ``log2_omega[row]``
    is ``log2 Ω_texel`` per row.
    """
    j = latlong_texel(lx, ly, lz, height, width)
    return pyramid_texel(j // width, j % width, np.log2(n * pdf), width, levels, offsets,
                         log2_omega)  # fmt: skip


@jit
def pyramid_texel(row, col, log2_density, width, levels, offsets, log2_omega):
    """:func:`filtered_texel` from the level-0 cell ``(row, col)`` the sample lands in and
    ``log2_density = log2(n p)``."""
    lod = -0.5 * (log2_density + log2_omega[row])
    k = min(max(int(np.floor(lod + LOD_BIAS)), 0), levels - 1)
    return offsets[k] + (row >> k) * (width >> k) + (col >> k)


@jit
def _plan_rows(views, normals, alphas, square, height, width, offsets, index, weight, count,
               b0, b1):  # fmt: skip
    n = square.shape[0]
    levels = offsets.shape[0] - 1
    log2_omega = log2_row_solid_angles(height, width)
    for t in range(b0, b1):
        nrm = (normals[t, 0], normals[t, 1], normals[t, 2])
        tan, bit, v_loc = surface_frame(views[t, 0], views[t, 1], views[t, 2], *nrm)
        frame = vndf_frame(alphas[t], alphas[t], v_loc[0], v_loc[1], v_loc[2])
        g1v = view_g1(v_loc[0], v_loc[1], v_loc[2], alphas[t])
        for k in range(n):
            lx, ly, lz, w0, _, pdf = sample_light_at(
                tan, bit, nrm, v_loc, alphas[t], frame, g1v, square[k, 0], square[k, 1]
            )
            if w0 > 0.0:
                index[t, k] = filtered_texel(
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


@jit
def _compact(index, weight, offsets, flat_index, flat_weight, b0, b1):
    for t in range(b0, b1):
        a = offsets[t]
        for k in range(offsets[t + 1] - a):
            flat_index[a + k] = index[t, k]
            flat_weight[a + k] = weight[t, k]


@jit
def _gather_many(offsets, index, weight, stacked, out, b0, b1):
    """``out[b, t] = Σ_k weight_k stacked[index_k, b]`` over target ``t``'s entries, for ``B``
    maps at once: ``stacked`` ``(texels, B, 3)``, ``out``
    ``(B, T, 3)``; each entry read once for all maps, sums per map in entry order,
    so a map's result does not depend on which maps share its pass."""
    n_maps = stacked.shape[1]
    if n_maps == 1:  # the same sums in registers (a probe of its own)
        for t in range(b0, b1):
            r = g = b = 0.0
            for k in range(offsets[t], offsets[t + 1]):
                j = index[k]
                w = weight[k]
                r += w * stacked[j, 0, 0]
                g += w * stacked[j, 0, 1]
                b += w * stacked[j, 0, 2]
            out[0, t, 0], out[0, t, 1], out[0, t, 2] = r, g, b
        return
    acc = np.empty((n_maps, 3))  # once per call, not per target (as prange hoisted it)
    for t in range(b0, b1):
        acc[:] = 0.0
        for k in range(offsets[t], offsets[t + 1]):
            j = index[k]
            w = weight[k]
            for b in range(n_maps):
                acc[b, 0] += w * stacked[j, b, 0]
                acc[b, 1] += w * stacked[j, b, 1]
                acc[b, 2] += w * stacked[j, b, 2]
        for b in range(n_maps):
            out[b, t, 0], out[b, t, 1], out[b, t, 2] = acc[b, 0], acc[b, 1], acc[b, 2]


@dataclass
class QuadraturePlan:
    """Texels and weights of ``E0`` at fixed ``(v, n, α)`` targets for one map shape.

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
    def build(cls, views, normals, alpha, samples: int, shape: tuple[int, int]):
        """The plan for ``(v, n, α)`` targets (``α`` the GGX width) and map ``shape``."""
        v, n, _ = check_geometry(views, normals, 1.0)
        a = check_alpha(alpha, v.shape[0])
        samples = check_samples(samples)
        levels = pyramid_levels(shape)
        index = np.empty((v.shape[0], samples), dtype=np.int32)
        weight = np.empty((v.shape[0], samples), dtype=np.float32)
        count = np.empty(v.shape[0], dtype=np.int64)
        square = fibonacci_square(samples)
        starts = level_offsets(shape, levels)
        run_blocks(_plan_rows, v.shape[0], v.shape[0] * samples * 300.0,
                   v, n, a, square, shape[0], shape[1], starts, index, weight, count)  # fmt: skip
        offsets = np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
        flat_index = np.empty(offsets[-1], dtype=np.int32)
        flat_weight = np.empty(offsets[-1], dtype=np.float32)
        run_blocks(_compact, v.shape[0], offsets[-1] * 16.0,
                   index, weight, offsets, flat_index, flat_weight)  # fmt: skip
        return cls(tuple(shape), levels, offsets, flat_index, flat_weight, v, n, a)

    @functools.cached_property
    def pair_groups(self):
        """:func:`pair_groups` of the plan's targets (once per plan)."""
        return pair_groups(self.views, self.normals)

    def _prepare(self, pixels):
        """The map's pyramid without its bright texels, and those as point lights."""
        flat, h, w = latlong_flat(pixels)
        if (h, w) != self.shape:
            raise ParameterError(f"plan is for {self.shape[1]}x{self.shape[0]} maps, got {w}x{h}")
        lights, dirs, energy = bright_texels(flat, h, w)
        if lights.size:
            flat = flat.copy()
            flat[lights] = 0.0
        return latlong_pyramid(flat, self.shape, self.levels), dirs, energy

    def e0(self, pixels) -> np.ndarray:
        """``E0`` at the plan's targets, ``(T, 3)`` float64."""
        return self.e0_many([pixels])[0]

    def e0_many(self, maps) -> list[np.ndarray]:
        """``E0`` of several maps in one pass over the plan's entries (each texel entry read
        once for all maps); each result equals :meth:`e0` of that map bit for bit."""
        prepared = [self._prepare(m) for m in maps]
        stacked = np.stack([p[0] for p in prepared], axis=1)  # (texels, B, 3)
        out = np.empty((len(prepared), self.offsets.shape[0] - 1, 3))
        n_targets = self.offsets.shape[0] - 1
        run_blocks(_gather_many, n_targets, self.index.shape[0] * len(prepared) * 20.0,
                   self.offsets, self.index, self.weight, stacked, out)  # fmt: skip
        for b, (_, dirs, energy) in enumerate(prepared):
            if dirs.shape[0]:
                order, starts = self.pair_groups
                run_blocks(_add_point_lights, starts.shape[0] - 1, n_targets * dirs.shape[0] * 40.0,
                           self.views, self.normals, self.alphas, dirs, energy, order, starts,
                           out[b])  # fmt: skip
        return list(out)
