"""Split-sum shading (Karis 2013): prefiltered radiance at the mirror direction × DFG.

``E(v, n, α) = L̃(ρ, α) (F0 A0(n·v, α) + (1 − F0) A1(n·v, α))``, ``ρ = 2(n·v)n − v``;
``L̃`` is fetched bilinearly from the two octahedral levels whose GGX widths
bracket ``α`` (:mod:`shbake.texture.octahedral`) and interpolated linearly in
``α`` (clamped to the levels); ``A0, A1`` from the asset's DFG table
(:mod:`shbake.shading.dfg`).
"""

import numpy as np

from shbake.jit import jit, run_blocks
from shbake.shading.dfg import dfg_at
from shbake.shading.shader import Texture, Uniform
from shbake.shading.shexp import DFG_INPUT, PROBE_MATERIAL_INPUTS, ProbeShader
from shbake.texture.octahedral import fetch as oct_fetch

PIXEL_BLOCK = 1024
"""Shading points per block of :func:`_evaluate_blocks` (the unit
:func:`~shbake.jit.run_blocks` hands to a thread)."""


@jit
def _evaluate_blocks(views, normals, alphas, f0, flat_levels, offsets, sizes, a_levels, table,
                     out, b0, b1):  # fmt: skip
    """Points ``b0·PIXEL_BLOCK … b1·PIXEL_BLOCK − 1`` of :func:`evaluate_splitsum`
    (check-free kernel)."""
    n_levels = sizes.shape[0]
    i_prev = -1
    lv0 = lv1 = flat_levels[:3].reshape((1, 1, 3))
    e0 = np.empty(3)
    e1 = np.empty(3)
    for k in range(b0 * PIXEL_BLOCK, min(views.shape[0], b1 * PIXEL_BLOCK)):
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
        if i0 != i_prev:  # the bracketing levels as arrays, rebuilt when they change
            i_prev = i0
            lv0 = flat_levels[offsets[i0] : offsets[i0 + 1]].reshape((sizes[i0], sizes[i0], 3))
            lv1 = flat_levels[offsets[i0 + 1] : offsets[i0 + 2]].reshape(
                (sizes[i0 + 1], sizes[i0 + 1], 3)
            )
        oct_fetch(lv0, rx, ry, rz, e0)
        oct_fetch(lv1, rx, ry, rz, e1)
        for c in range(3):
            pre = (1 - t) * e0[c] + t * e1[c]
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
    run_blocks(
        _evaluate_blocks, -(-v.shape[0] // PIXEL_BLOCK), v.shape[0] * 60.0,
        v, n, a, f0, flat, offsets, sizes, np.asarray(level_alpha, float),
        np.asarray(table, float), out,
    )  # fmt: skip
    return out


class SplitsumShader(ProbeShader):
    """A ``splitsum_probe``: prefiltered radiance at the mirror direction times
    ``F0 A0 + (1 − F0) A1`` (module docstring; :func:`evaluate_splitsum`)."""

    name = "splitsum"
    glsl = "splitsum.glsl:shbakeSplitSum"
    kinds = ("splitsum_probe",)
    inputs = (
        Texture("levels", "octahedral", ("S", "S", 3), "/levels/{k}",
                "prefiltered radiance, one octahedral image per level k (S halves per level)"),
        Uniform("level_alpha", "GGX width α of each level", "/level_alpha", "increasing"),
        DFG_INPUT,
        *PROBE_MATERIAL_INPUTS,
    )  # fmt: skip

    def shade(self, normals, views, alpha=None, f0=1.0):
        a, m = self.asset, self.check(alpha, f0)
        levels = [a[f"/levels/{k}"] for k in range(int(a.attrs["levels"]))]
        return evaluate_splitsum(levels, a["/level_alpha"], a["/dfg"], views, normals,
                                 m["alpha"], m["f0"])  # fmt: skip
