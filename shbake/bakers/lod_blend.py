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
``L_k`` (each ``E_j`` read bilinearly, as the GPU reads it) against the prefiltered
radiance at that lod's roughness (the chain's own estimator,
:func:`shbake.bakers.cube_prefilter.prefilter_points`), each residual divided by the
target's luminance (relative error, what the engines are judged by). The identity
(``C = I``) is one candidate, so on those points the fit is never worse than exact levels.
The fitted ``C`` is near ``L_k ≈ 1.25 E_k − 0.15 (E_{k−1} + E_{k+1})``: each level sharpened
against its neighbours, which the blend then softens back.

Measured (three.js's 512² → 4² chain, its lod rule and the tests' sphere pixels, chain read
as the GPU does against the converged brute force, p95): the mirror on esplanade 24.0 →
10.6 %, studio 46.5 → 12.1 %; studio r 0.3 median 5.8 → 0.7 %; r 0.6 unchanged (its levels
are exact). Refitting the rough levels too (every level but the last) raised studio's
r 0.6 from 7.6 to 16.8 %: a least-squares fit over all lods trades the rough end's tail
for the sharp end's, so those levels stay exact.
"""

import math

import numpy as np

from shbake.bakers.cube_prefilter import (
    FIT_DENSITY,
    HotTexels,
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


def blend_coefficients(
    levels: list[np.ndarray],
    fitted: range,
    mapping: str,
    source: list[np.ndarray],
    hot: HotTexels | None,
    lod_min: float,
) -> np.ndarray:
    """``C`` (``len(fitted) × (fitted.stop + 1)``): level ``fitted[i]`` becomes
    ``Σ_j C[i, j] levels[j]`` (module docstring). ``source``/``hot``: the chain's FIS
    pyramid and excess texels (:func:`shbake.bakers.cube_prefilter.split_hot_texels`)."""
    n, size = len(levels), levels[0].shape[1]
    top = fitted.stop
    frames = world_face_frames()
    dirs = fibonacci_sphere(BLEND_DIRECTIONS)
    lods = np.linspace(lod_min, top, int(math.ceil((top - lod_min) * BLEND_LODS_PER_LEVEL)) + 1)
    target = np.stack([
        prefilter_points(source, dirs, ggx_alpha(roughness_of_level(ell, n, mapping, size)),
                         BLEND_SAMPLES, hot=hot) @ REC709_LUMINANCE
        for ell in lods
    ])  # fmt: skip
    basis = np.stack([sample_cube(levels[j], dirs, frames) @ REC709_LUMINANCE
                      for j in range(top + 1)])  # fmt: skip
    # what the levels kept exact add at each lod (levels below `fitted` have no weight there)
    rest = _hat(top, lods)[:, None] * basis[top][None]
    hats = np.stack([_hat(k, lods) for k in fitted], axis=1)  # (lods, fitted)
    design = hats[:, None, :, None] * basis.T[None, :, None, :]  # (lods, dirs, fitted, basis)
    weight = 1.0 / np.maximum(target, 1e-6 * max(float(target.mean()), 1e-300))
    a = (design * weight[..., None, None]).reshape(-1, len(fitted) * (top + 1))
    b = ((target - rest) * weight).reshape(-1)
    return np.linalg.lstsq(a, b, rcond=None)[0].reshape(len(fitted), top + 1)


def _level_on_grid(level: np.ndarray, m: int) -> np.ndarray:
    """``level`` at the texel centres of an ``m``² cube: box-averaged down to it when finer,
    read bilinearly at them otherwise. ``(6, m, m, 3)``."""
    while level.shape[1] > m:
        level = downsample_cube(level)
    if level.shape[1] == m:
        return level
    dirs = cube_directions(m)[0].reshape(-1, 3)
    return sample_cube(level, dirs, world_face_frames()).reshape(6, m, m, 3)


def fit_lod_blend(
    levels: list[np.ndarray],
    mapping: str,
    source: list[np.ndarray],
    hot: HotTexels | None,
    lod_min: float,
) -> tuple[list[np.ndarray], np.ndarray]:
    """The chain ``levels`` (exact lobes, level 0 first, ``mapping``'s roughness per level)
    with :func:`blended_levels` replaced by the combinations of :func:`blend_coefficients`,
    for an engine that reads it at ``lod`` ≥ ``lod_min``. A level of at most
    ``FIT_MAX_SIZE``² faces is made at ``FIT_DENSITY`` × its edge and fitted to the GPU's
    bilinear read (:func:`shbake.bakers.cube_prefilter.fit_bilinear`), like the level it
    replaces. Returns ``(levels, C)`` (``C``: zero rows when nothing is refitted)."""
    size = levels[0].shape[1]
    fitted = blended_levels(len(levels), mapping, size, lod_min)
    if not len(fitted):
        return list(levels), np.zeros((0, 0))
    coeffs = blend_coefficients(levels, fitted, mapping, source, hot, lod_min)
    out = list(levels)
    for row, k in enumerate(fitted):
        n = levels[k].shape[1]
        m = n if n > FIT_MAX_SIZE else FIT_DENSITY * n
        mixed = sum(c * _level_on_grid(levels[j], m) for j, c in enumerate(coeffs[row]))
        mixed = np.maximum(mixed, 0.0)
        out[k] = mixed if m == n else fit_bilinear(mixed, n)
    return out, coeffs


__all__ = [
    "BLEND_DIRECTIONS",
    "BLEND_LODS_PER_LEVEL",
    "BLEND_SAMPLES",
    "blend_coefficients",
    "blended_levels",
    "fit_lod_blend",
]
