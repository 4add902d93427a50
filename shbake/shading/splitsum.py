"""Split-sum shading (Karis 2013): prefiltered radiance at the mirror direction × DFG.

``E(v, n, α) = L̃(ρ, α) (F0 A0(n·v, α) + (1 − F0) A1(n·v, α))``, ``ρ = 2(n·v)n − v``;
``L̃`` is fetched bilinearly from the two octahedral levels whose GGX widths
bracket ``α`` (:mod:`shbake.texture.octahedral`) and interpolated linearly in
``α`` (clamped to the levels); ``A0, A1`` from the asset's DFG table
(:mod:`shbake.shading.dfg`).
"""

import numba
import numpy as np

from shbake.jit import pjit
from shbake.shading.dfg import dfg_at
from shbake.texture.octahedral import fetch as oct_fetch


@pjit
def _evaluate(views, normals, alphas, f0, flat_levels, offsets, sizes, a_levels, table, out):
    n_levels = sizes.shape[0]
    for k in numba.prange(views.shape[0]):
        vx, vy, vz = views[k, 0], views[k, 1], views[k, 2]
        nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
        nv = nx * vx + ny * vy + nz * vz
        rx, ry, rz = 2 * nv * nx - vx, 2 * nv * ny - vy, 2 * nv * nz - vz
        a = min(max(alphas[k], a_levels[0]), a_levels[n_levels - 1])
        i0 = 0
        while i0 < n_levels - 2 and a > a_levels[i0 + 1]:
            i0 += 1
        t = (a - a_levels[i0]) / (a_levels[i0 + 1] - a_levels[i0])
        a0, a1 = dfg_at(table, nv, alphas[k])
        lv0 = flat_levels[offsets[i0] : offsets[i0 + 1]].reshape((sizes[i0], sizes[i0], 3))
        lv1 = flat_levels[offsets[i0 + 1] : offsets[i0 + 2]].reshape(
            (sizes[i0 + 1], sizes[i0 + 1], 3)
        )
        for c in range(3):
            pre = (1 - t) * oct_fetch(lv0, rx, ry, rz, c) + t * oct_fetch(lv1, rx, ry, rz, c)
            out[k, c] = pre * (f0[c] * a0 + (1.0 - f0[c]) * a1)


def evaluate_splitsum(levels, level_alpha, table, views, normals, alpha, f0=(1.0,) * 3):
    """Outgoing radiance ``(T, 3)`` of a split-sum probe at world ``(v, n, α)``.

    ``levels``: octahedral ``(s_k, s_k, 3)`` images; ``level_alpha``: their
    increasing GGX widths; ``alpha``: GGX width, scalar or ``(T,)``.
    """
    sizes = np.array([lv.shape[0] for lv in levels], dtype=np.int64)
    flat = np.concatenate([np.asarray(lv, float).reshape(-1) for lv in levels])
    offsets = np.concatenate([[0], np.cumsum(sizes * sizes * 3)]).astype(np.int64)
    v = np.ascontiguousarray(np.asarray(views, float).reshape(-1, 3))
    n = np.ascontiguousarray(np.asarray(normals, float).reshape(-1, 3))
    a = np.broadcast_to(np.asarray(alpha, float), (v.shape[0],)).copy()
    out = np.empty((v.shape[0], 3))
    f0 = np.broadcast_to(np.asarray(f0, float), (3,)).copy()
    _evaluate(
        v, n, a, f0, flat, offsets, sizes, np.asarray(level_alpha, float),
        np.asarray(table, float), out,
    )  # fmt: skip
    return out
