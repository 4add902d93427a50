"""A cube chain's sharp levels refitted to the engine's linear blend between levels.

An engine reads a prefiltered chain at a fractional ``lod`` of the surface's roughness and
blends the two levels around it linearly
(:func:`shbake.format.exports.cube_chain.read_chain`). Between two levels that each hold
their own roughness's lobe ``E_i = P(·, α_i)`` (Karis 2013 eq. 4), that blend is not the lobe
of the roughness between: near a source far brighter than its surroundings the lobe's tail
grows as ``α²`` while the blend's weight grows as ``r`` (≈ ``√α``), so the blend overstates
the tail. three.js reads its "mirror" (its roughness floor, 0.045, plus the geometry
roughness) at ``lod`` ≈ 0.8 of an eight-level chain: 20 % of the mirror level, 80 % of level
1. With every level exact, that blend is 19.6 % (esplanade) and 41.4 % (studio) from the
lobe at the 95th percentile (``bench/engine_lod_floor.py``).

An engine that never reads below ``lod_min > 0`` (a roughness floor) leaves the content of
the levels free: each level only has to make the *blends* right. So the levels ``k`` with
``lod_min - 1 < k < K`` (``K``: the first level of roughness
:data:`BLEND_MAX_ROUGHNESS` or more) are replaced by combinations of the chain's own
levels, ``L_k = max(0, Σ_j C_kj E_j)`` (``j ≤ K``), ``C`` fitted per map by linear least
squares: at :data:`BLEND_DIRECTIONS` spherical-Fibonacci directions and at lods
:data:`BLEND_LODS_PER_LEVEL` per level apart across ``[lod_min, K]``, the blend of the
``L_k`` (each ``E_j`` as level ``k`` holds it on its grid, read bilinearly as the GPU
reads it) against the prefiltered radiance at that lod's roughness (the chain's own
estimator, :func:`shbake.bakers.cube_prefilter.prefilter_points`), each residual divided
by the target's luminance (relative error, what the engines are judged by). The identity
(``C = I``) is one candidate; the refitted chain is kept only if its blend, read back at
those points, is nearer the targets than the exact levels' (a 64² → 2² chain of esplanade
averaged to 128 × 64 gains nothing: the exact levels are kept, where the refit alone read
35.3 → 58.1 % p95).
The fitted ``C`` is near ``L_k ≈ 1.25 E_k − 0.15 (E_{k−1} + E_{k+1})``: each level sharpened
against its neighbours, which the blend then softens back.

Measured on three.js's 512² → 4² chain read as the GPU does (:func:`read_chain` at the
rendered-engine tests' sphere pixels and lods) against the converged brute force, p95: the
mirror on esplanade 24.0 → 10.6 %, studio 46.5 → 12.1 %; studio r 0.3 median 5.8 → 0.7 %;
r 0.6 unchanged (its levels are exact). Rendered by three.js itself: esplanade 21.9 →
9.9 %, studio 46.8 → 11.5 % (docs/BENCHMARKS.md). Refitting the rough levels too (every
level but the last) raised studio's r 0.6 from 7.6 to 16.8 %: a least-squares fit over all
lods trades the rough end's tail for the sharp end's, so those levels stay exact.
"""

import math

import numpy as np

from shbake.bakers.cube_prefilter import (
    FIT_DENSITY,
    HotTexels,
    bilinear_taps,
    cube_directions,
    downsample_cube,
    fit_bilinear,
    prefilter_points,
)
from shbake.conventions import REC709_LUMINANCE, ggx_alpha
from shbake.format.exports.cube_chain import (
    BLEND_MAX_ROUGHNESS,
    FIT_MAX_SIZE,
    roughness_of_level,
    world_face_frames,
)
from shbake.sh.point_sets import fibonacci_sphere
from shbake.texture.cube import sample_cube

BLEND_DIRECTIONS = 2048
"""Directions the blend is fitted at (spherical Fibonacci)."""
BLEND_LODS_PER_LEVEL = 4
"""Target lods per level of the fitted range. Measured on studio (mirror p95): 6 per level
at 4096 directions and 1024 samples 13.2 %, 4 at 2048 and 512 samples 12.1 % (fit 5.3 →
2.5 s); 2 per level misses the lods between (43.9 % in the ideal-chain model)."""
BLEND_SAMPLES = 512
"""GGX samples per target point (filtered importance sampling)."""


def blended_levels(n_levels: int, mapping: str, size: int, lod_min: float) -> range:
    """The levels :func:`fit_lod_blend` refits: from the first one an engine reading at
    ``lod`` ≥ ``lod_min`` blends, up to the last below :data:`BLEND_MAX_ROUGHNESS`
    (empty when ``lod_min`` is 0: the engine reads level 0 alone)."""
    if lod_min <= 0.0:
        return range(0)
    first = last = int(math.floor(lod_min))
    while last < n_levels - 1 and (
        roughness_of_level(last, n_levels, mapping, size) < BLEND_MAX_ROUGHNESS
    ):
        last += 1
    return range(first, last)


def _hat(k: int, lods: np.ndarray) -> np.ndarray:
    """Weight of level ``k`` in a linear blend read at ``lods``."""
    return np.maximum(0.0, 1.0 - np.abs(lods - k))


def _grid_edge(n: int) -> int:
    """Edge of the grid a refitted level of ``n``² faces is made on: its own, or
    ``FIT_DENSITY × n`` for a level fitted to the bilinear read (``n ≤ FIT_MAX_SIZE``)."""
    return n if n > FIT_MAX_SIZE else FIT_DENSITY * n


def _level_on_grid(level: np.ndarray, m: int, centres: np.ndarray) -> np.ndarray:
    """``level`` at the texel centres of an ``m``² cube (``centres``: their directions,
    ``(6 m², 3)``): box-averaged down to it when finer, read bilinearly at them otherwise.
    ``(6, m, m, 3)``."""
    while level.shape[1] > m:
        level = downsample_cube(level)
    if level.shape[1] == m:
        return level
    return sample_cube(level, centres, world_face_frames()).reshape(6, m, m, 3)


def _reads_on_grid(levels: list[np.ndarray], m: int, dirs: np.ndarray) -> np.ndarray:
    """Luminance of each of ``levels`` as an ``m``² grid holds it (:func:`_level_on_grid`),
    read bilinearly at ``dirs``: ``(len(levels), len(dirs))``. Only the texels those reads
    take are made (a 512² grid: a few thousand, not 1.5 million)."""
    offsets, index, weight = bilinear_taps(dirs, m)
    used, inverse = np.unique(index, return_inverse=True)
    at = cube_directions(m)[0].reshape(-1, 3)[used]
    rows = np.repeat(np.arange(len(dirs)), np.diff(offsets))
    out = []
    for level in levels:
        while level.shape[1] > m:
            level = downsample_cube(level)
        if level.shape[1] == m:
            values = level.reshape(-1, 3)[used]
        else:
            values = sample_cube(level, at, world_face_frames())
        y = (values @ REC709_LUMINANCE)[inverse.reshape(-1)]
        out.append(np.bincount(rows, weights=weight * y, minlength=len(dirs)))
    return np.stack(out)


def _blend_error(reads: np.ndarray, lods: np.ndarray, target: np.ndarray) -> float:
    """Sum of squared relative errors of a chain's luminance ``reads`` (levels × dirs) blended
    at ``lods`` against ``target`` (lods × dirs)."""
    blend = np.stack([_hat(k, lods) for k in range(len(reads))], axis=1) @ reads
    return float((((blend - target) / target) ** 2).sum())


def fit_lod_blend(
    levels: list[np.ndarray],
    mapping: str,
    source: list[np.ndarray],
    hot: HotTexels | None,
    lod_min: float,
) -> tuple[list[np.ndarray], np.ndarray]:
    """The chain ``levels`` (exact lobes, level 0 first, ``mapping``'s roughness per level)
    with :func:`blended_levels` replaced by combinations of the levels, for an engine that
    reads it at ``lod`` ≥ ``lod_min`` (module docstring). ``source``/``hot``: the chain's
    FIS pyramid and excess texels (:func:`shbake.bakers.cube_prefilter.split_hot_texels`),
    which the targets are prefiltered from.

    Level ``k`` is made on its grid (:func:`_grid_edge`: at ``FIT_DENSITY`` × its edge, then
    fitted to the GPU's bilinear read by :func:`shbake.bakers.cube_prefilter.fit_bilinear`,
    for a level of at most ``FIT_MAX_SIZE``² faces), and the least squares read each
    ``E_j`` as it lies on that grid, so the fit models the level it builds. The refitted
    chain is kept only where its blend, read back at the fit's points, is nearer the targets
    than the exact levels'. Returns ``(levels, C)``, ``C`` (``len(fitted) × (K + 1)``) with
    no rows when nothing is refitted."""
    n, size = len(levels), levels[0].shape[1]
    fitted = blended_levels(n, mapping, size, lod_min)
    if not len(fitted):
        return list(levels), np.zeros((0, 0))
    top = fitted.stop
    frames = world_face_frames()
    dirs = fibonacci_sphere(BLEND_DIRECTIONS)
    lods = np.linspace(lod_min, top, int(math.ceil((top - lod_min) * BLEND_LODS_PER_LEVEL)) + 1)
    target = np.stack([
        prefilter_points(source, dirs, ggx_alpha(roughness_of_level(ell, n, mapping, size)),
                         BLEND_SAMPLES, hot=hot) @ REC709_LUMINANCE
        for ell in lods
    ])  # fmt: skip
    target = np.maximum(target, 1e-6 * max(float(target.mean()), 1e-300))

    def read(level):
        return sample_cube(level, dirs, frames) @ REC709_LUMINANCE

    # basis[i, j]: E_j as level fitted[i] holds it (on its grid), read at dirs
    basis = np.stack([_reads_on_grid(levels[: top + 1], _grid_edge(levels[k].shape[1]), dirs)
                      for k in fitted])  # fmt: skip
    exact = np.stack([read(lv) for lv in levels[: top + 1]])
    rest = _hat(top, lods)[:, None] * exact[top][None]  # levels below `fitted`: no weight
    hats = np.stack([_hat(k, lods) for k in fitted], axis=1)  # (lods, fitted)
    design = hats[:, None, :, None] * basis.transpose(2, 0, 1)[None]  # (lods, dirs, fitted, j)
    weight = 1.0 / target
    a = (design * weight[..., None, None]).reshape(-1, basis.shape[0] * basis.shape[1])
    b = ((target - rest) * weight).reshape(-1)
    coeffs = np.linalg.lstsq(a, b, rcond=None)[0].reshape(basis.shape[:2])
    out = list(levels)
    for row, k in enumerate(fitted):
        edge = levels[k].shape[1]
        m = _grid_edge(edge)
        centres = cube_directions(m)[0].reshape(-1, 3)  # once per level, not per term
        mixed = np.zeros((6, m, m, 3))
        for j, c in enumerate(coeffs[row]):
            mixed += c * _level_on_grid(levels[j], m, centres)
        mixed = np.maximum(mixed, 0.0)
        out[k] = mixed if m == edge else fit_bilinear(mixed, edge)
    refit = np.stack([read(lv) for lv in out[: top + 1]])
    if _blend_error(refit, lods, target) >= _blend_error(exact, lods, target):
        return list(levels), np.zeros((0, 0))
    return out, coeffs


__all__ = [
    "BLEND_DIRECTIONS",
    "BLEND_LODS_PER_LEVEL",
    "BLEND_SAMPLES",
    "blended_levels",
    "fit_lod_blend",
]
