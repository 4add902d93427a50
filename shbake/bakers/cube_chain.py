"""A GGX prefiltered cube chain as an engine takes it: levels filtered, then fitted to its reads.

:func:`prefilter_chain` assembles the chain an export writes: level 0 the mirror map,
each further level the GGX lobe of its roughness (``mapping``,
:mod:`shbake.format.exports.cube_chain`) by filtered importance sampling
(:mod:`shbake.bakers.cube_prefilter`); the small levels fitted to the GPU's bilinear read
(:func:`shbake.bakers.cube_prefilter.fit_bilinear`) and, for an engine with a roughness floor
(``min_roughness``), the sharp levels refitted to its linear blend between levels
(:mod:`shbake.bakers.lod_blend`). Its memory estimate and layout checks come first.
"""

import math

import numpy as np

from shbake.bakers.cube_prefilter import (
    DEFAULT_SAMPLES,
    FIT_DENSITY,
    cube_pyramid,
    downsample_cube,
    fit_bilinear,
    mirror_cube,
    mirror_supersample,
    prefilter_level,
    split_hot_texels,
)
from shbake.bakers.lod_blend import fit_lod_blend
from shbake.conventions import ggx_alpha
from shbake.envmap.environment import Environment
from shbake.errors import ParameterError
from shbake.format.exports.cube_chain import FIT_MAX_SIZE, level_of_roughness, roughness_of_level
from shbake.resources import check_memory


def chain_memory(size: int, source_size: int, cube_input: bool, supersample: int = 1) -> int:
    """Estimated peak bytes of :func:`prefilter_chain`: the FIS source cube (``6 × source²``
    float64 RGB; with its pyramid, the pyramid packed into one array and their transients
    4.5 such cubes: the map without its hot texels' excess, :func:`split_hot_texels`) and
    the levels (twice); for a ``cube_input`` map also the source's sub-texel directions
    (``6 × source² × supersample²`` float64 triples, ``supersample`` its
    :func:`mirror_supersample`, four copies while they are made, normalised, reordered and
    fetched; :func:`mirror_cube` reads a lat-long map texel by texel and keeps none); 10 %
    over their sum. Measured peaks (``tracemalloc``) are 0.5–0.9 of it
    (``tests/system/faults/test_memory.py``)."""
    src = int(source_size) * int(source_size)
    directions = 6 * src * supersample * supersample * 3 * 8 * 4 if cube_input else 0
    return int(1.1 * (directions + 6 * src * 24 * 4.5 + 6 * int(size) ** 2 * 24 * 2))


CUBE_SIZE_LIMIT = 4096
"""Largest level-0 face edge of a prefiltered chain (its mirror cube is twice as wide)."""


def check_chain(size: int, floor: int, samples: int) -> None:
    """Refuse a chain layout :func:`prefilter_chain` cannot build: ``size`` and ``floor``
    powers of two with ``1 ≤ floor ≤ size ≤ CUBE_SIZE_LIMIT``, ``samples ≥ 1``."""
    for name, v in (("size", size), ("floor", floor)):
        if not 1 <= v <= CUBE_SIZE_LIMIT or v & (v - 1):
            raise ParameterError(
                f"{name} must be a power of two in [1, {CUBE_SIZE_LIMIT}], got {v}"
            )
    if floor > size:
        raise ParameterError(f"floor {floor} exceeds size {size}")
    if samples < 1:
        raise ParameterError(f"samples must be >= 1, got {samples}")


def level_samples(samples: int, level: int) -> int:
    """GGX samples per texel at chain ``level``: ``samples`` up to level 1, doubled at each
    level from 2 on, as cmgen does (``tools/cmgen/src/cmgen.cpp`` ``iblRoughnessPrefilter``:
    "starting at level 2, we increase the number of samples per level ... since there are 4x
    less work per level, this doesn't slow things down a lot"): a chain costs about twice its
    level 1. A wider lobe meets more of a map's small bright sources; with ``samples`` at
    every level the rough levels miss them: esplanade (its sun 29 856), 8² faces at r 0.59,
    3.5 % median / 18.6 % p95 from brute force with 512 samples, 0.6 % / 4.7 % with 4096."""
    return int(samples) << max(0, level - 1)


def prefilter_chain(
    env: Environment,
    size: int = 128,
    floor: int = 1,
    mapping: str = "gltf-ibl-sampler",
    samples: int = DEFAULT_SAMPLES,
    source_size: int | None = None,
    fis: bool = True,
    rotation: np.ndarray | None = None,
    min_roughness: float = 0.0,
) -> tuple[list[np.ndarray], list[float]]:
    """The GGX prefiltered cube mip chain of ``env``.

    Parameters
    ----------
    size : power of two
        Level-0 face edge (the mirror map).
    floor : power of two, 1 … size
        Smallest level edge; the chain has ``log2(size/floor) + 1`` levels.
    mapping : one of :data:`LOD_MAPPINGS`
        Perceptual roughness of each level (module docstring).
    samples : int
        GGX samples per texel (filtered importance sampling) up to level 1, doubled per
        level after (:func:`level_samples`).
    source_size : power of two
        Edge of the mirror cube the filter reads (default ``2*size``).
    rotation : 3×3, optional
        Target ← world rotation (:func:`mirror_cube`).
    min_roughness : float, 0 … 1
        The least perceptual roughness the engine reads the chain at (its shader's floor).
        Above 0, the levels it only ever reads blended are refitted to its blend
        (:func:`shbake.bakers.lod_blend.fit_lod_blend`).

    Returns
    -------
    (levels, roughness)
        ``levels[i]`` is ``(6, size >> i, size >> i, 3)`` float64;
        ``roughness[i]`` its perceptual roughness (``α = r²``).
    """
    check_chain(size, floor, samples)
    n_levels = int(round(math.log2(size // floor))) + 1
    src = source_size or 2 * size
    check_memory(chain_memory(size, src, env.layout != "latlong", mirror_supersample(env, src)),
                 f"a cube chain of {size}² faces from {src}² faces")  # fmt: skip
    rest, hot = split_hot_texels(env, rotation)
    # the FIS source: the map without the hot texels' excess (summed exactly per level)
    source = cube_pyramid(mirror_cube(rest, src, mirror_supersample(rest, src), rotation))
    levels, rough = [], []
    for i in range(n_levels):
        r = roughness_of_level(i, n_levels, mapping, size)
        n = size >> i
        if i == 0 or r == 0.0:
            lvl = mirror_cube(env, n, mirror_supersample(env, n), rotation)
        elif n <= FIT_MAX_SIZE:
            dense = prefilter_level(source, FIT_DENSITY * n, ggx_alpha(r),
                                    level_samples(samples, i) // 2, fis, hot)  # fmt: skip
            lvl = fit_bilinear(dense, n)
        else:
            lvl = prefilter_level(source, n, ggx_alpha(r), level_samples(samples, i), fis, hot)
        levels.append(lvl)
        rough.append(r)
    if min_roughness > 0.0:
        lod_min = level_of_roughness(min_roughness, n_levels, mapping, size)
        levels = fit_lod_blend(levels, mapping, source, hot, lod_min)[0]
    return levels, rough


def extend_chain(levels: list, roughness: list) -> tuple[list, list]:
    """The chain continued down to 1² faces by :func:`downsample_cube` of its last level, each
    added level at the last level's roughness (a Babylon ``.env`` holds every level; a
    ``babylon`` chain ends at ``α = 1``, so the added ones are never read below ``r = 1``)."""
    levels, roughness = list(levels), list(roughness)
    while levels[-1].shape[1] > 1:
        levels.append(downsample_cube(levels[-1]))
        roughness.append(roughness[-1])
    return levels, roughness


__all__ = [
    "CUBE_SIZE_LIMIT",
    "chain_memory",
    "check_chain",
    "extend_chain",
    "level_samples",
    "prefilter_chain",
]
