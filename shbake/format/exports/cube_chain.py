"""How engines read a GGX prefiltered cube chain: its faces and the roughness of each level.

Roughness ↔ LOD (``lod_fraction f = i / (n-1)``, perceptual roughness ``r``,
``α = r²``, shbake.conventions):

``gltf-ibl-sampler`` (default)
    ``r = f`` (glTF-IBL-Sampler ``main.cpp``: ``roughness = lod / (mipCount-1)``).
``filament``
    ``f = r (2 - r)``, so ``r = 1 - sqrt(1 - f)`` (Filament
    ``lodToPerceptualRoughness``: ``a = 2, b = -1``).
``babylon``
    Babylon.js's shader: ``lod = s · log2(N0 · α)`` with ``s = (n-1)/log2(N0)``
    (``pbrIBLFunctions`` ``getLodFromAlphaG``, the glTF loader's and a full .env chain's
    ``lodGenerationScale``), so level ``i > 0`` holds ``α = N0^(f - 1)`` (``α`` doubles
    per level in a full chain; the last is ``α = 1``); level 0 is the mirror, as
    Babylon's own ``HDRFiltering`` bakes it. Depends on ``N0`` (the level-0 edge).

Cube geometry: OpenGL/Vulkan/KTX face order and orientation (GL 4.6 spec
table 8.19): face ``k`` (+X, −X, +Y, −Y, +Z, −Z), texel row ``i`` (top = 0),
column ``j``, ``s = 2(j+½)/n − 1``, ``t = 2(i+½)/n − 1``, GL direction
``g = s·a_s + t·a_t + a_n``. Engines sample a right-handed world direction
``d`` at ``g = (−d_x, d_y, d_z)`` (three.js ``flipEnvMap = −1`` for cube
textures; Babylon's glTF loader mirrors glTF ``x``), so texel directions are
``d = (−g_x, g_y, g_z)``. Texel solid angles are the exact ones of
:func:`shbake.envmap.layouts.cube_texels` (the same grid on every face).
Every output texel is computed at its own direction, so faces agree along
their shared edges (no seam).

An engine reads the chain at ``lod`` = :func:`level_of_roughness` of the surface's
roughness, blending the two levels around it linearly (``textureLod`` with
``LINEAR_MIPMAP_LINEAR``): :func:`read_chain`.
"""

import math

import numpy as np

from shbake.conventions import ggx_alpha, perceptual_roughness
from shbake.errors import ParameterError
from shbake.texture.cube import sample_cube

# GL cube faces: columns (s axis, t axis, face normal) in GL cube space.
GL_FACES = np.array(
    [
        [[0, 0, 1], [0, -1, 0], [-1, 0, 0]],  # +X: sc = -z, tc = -y
        [[0, 0, -1], [0, -1, 0], [1, 0, 0]],  # -X: sc = +z, tc = -y
        [[1, 0, 0], [0, 0, 1], [0, 1, 0]],  # +Y: sc = +x, tc = +z
        [[1, 0, 0], [0, 0, -1], [0, -1, 0]],  # -Y: sc = +x, tc = -z
        [[1, 0, 0], [0, -1, 0], [0, 0, 1]],  # +Z: sc = +x, tc = -y
        [[-1, 0, 0], [0, -1, 0], [0, 0, -1]],  # -Z: sc = -x, tc = -y
    ],
    dtype=np.float64,
)
"""``GL_FACES[k] @ (s, t, 1)``: GL direction on face ``k`` (columns: s axis, t axis, normal)."""

WORLD_FROM_GL = np.diag([-1.0, 1.0, 1.0])
"""World direction of GL cube direction ``g``: ``d = WORLD_FROM_GL @ g`` (an x mirror)."""

LOD_MAPPINGS = ("gltf-ibl-sampler", "filament", "babylon")
FIT_MAX_SIZE = 64
"""Largest level face a chain fits to the GPU's bilinear read
(:func:`shbake.bakers.cube_prefilter.fit_bilinear`) rather than samples at its texel
centres: the rough levels, where the lobe is not wide against a texel and the fit pays most
(studio, 4096 directions, p95: three.js's r 0.6 14.7 → 5.9 %, Babylon.js's 63.3 → 21.5 %),
at twice the samples of those levels (2 × 2 points a texel, half the level's samples each:
6.0 s against 10.5 s with the level's own, r 0.3 6.4 against 6.3 %). The sharp levels gain
little (r 0.1: 20.5 → 19.9 %)."""

BLEND_MAX_ROUGHNESS = 0.45
"""Levels of this perceptual roughness or more keep their exact lobe when a chain's sharp
levels are refitted to an engine's blend between levels (:mod:`shbake.bakers.lod_blend`):
refitting every level but the last raised studio's r 0.6 from 7.6 to 16.8 % p95 (three.js's
rule, 512² → 4²), fitting those below it lowers the mirror from 46.5 to 12.1 %."""

BABYLON_MIN_ALPHA = 0.0005
"""Babylon.js adds this to every ``α = r²`` (``pbrHelperFunctions`` ``MINIMUMVARIANCE``)."""


def world_face_frames() -> np.ndarray:
    """``(6, 3, 3)``: world direction of face ``k`` at ``(s, t)`` is ``F[k] @ (s, t, 1)``."""
    return np.einsum("ij,kjl->kil", WORLD_FROM_GL, GL_FACES)


def _check_mapping(mapping: str) -> None:
    if mapping not in LOD_MAPPINGS:
        raise ParameterError(f"unknown roughness/LOD mapping {mapping!r}; choose {LOD_MAPPINGS}")


def roughness_of_level(
    level: int, levels: int, mapping: str = "gltf-ibl-sampler", size: int = 0
) -> float:
    """Perceptual roughness ``r`` stored at mip ``level`` of a chain of ``levels``
    (``size``: the level-0 edge, which the ``babylon`` mapping depends on)."""
    _check_mapping(mapping)
    if levels < 2 or level == 0:
        return 0.0
    f = level / (levels - 1)
    if mapping == "gltf-ibl-sampler":
        return f
    if mapping == "filament":
        return 1.0 - math.sqrt(max(0.0, 1.0 - f))
    return perceptual_roughness(float(size) ** (f - 1.0))


def level_of_roughness(r: float, levels: int, mapping: str = "gltf-ibl-sampler", size: int = 0):
    """Fractional mip level an engine samples for perceptual roughness ``r`` (inverse map;
    ``babylon``: ``α = r² +`` :data:`BABYLON_MIN_ALPHA`, clamped to the chain as the GPU does)."""
    _check_mapping(mapping)
    if mapping == "gltf-ibl-sampler":
        return r * (levels - 1)
    if mapping == "filament":
        return r * (2.0 - r) * (levels - 1)
    if levels < 2:
        return 0.0
    lod = (levels - 1) / math.log2(size) * math.log2(size * (ggx_alpha(r) + BABYLON_MIN_ALPHA))
    return min(max(lod, 0.0), levels - 1.0)


def read_chain(levels: list, directions: np.ndarray, lod) -> np.ndarray:
    """The chain ``levels`` (``(6, n_i, n_i, 3)``, these faces, level 0 first) read along
    world ``directions (..., 3)`` at ``lod`` (a scalar or one per direction, clamped to the
    chain) as a GPU's trilinear ``textureLod`` does: each of the two levels around it by a
    seam-correct bilinear fetch (:func:`shbake.texture.cube.sample_cube`), blended
    linearly by the fraction. Returns ``(..., 3)``."""
    d = np.asarray(directions, dtype=np.float64)
    lods = np.clip(np.broadcast_to(np.asarray(lod, dtype=np.float64), d.shape[:-1]),
                   0.0, len(levels) - 1.0).reshape(-1)  # fmt: skip
    flat = d.reshape(-1, 3)
    below = np.minimum(np.floor(lods).astype(int), max(len(levels) - 2, 0))
    t = (lods - below)[:, None]
    frames = world_face_frames()
    out = np.zeros((flat.shape[0], 3))
    for k in np.unique(below):
        m = below == k
        out[m] = (1.0 - t[m]) * sample_cube(levels[k], flat[m], frames)
        if len(levels) > 1:
            out[m] += t[m] * sample_cube(levels[k + 1], flat[m], frames)
    return out.reshape(d.shape)


__all__ = [
    "BABYLON_MIN_ALPHA",
    "BLEND_MAX_ROUGHNESS",
    "FIT_MAX_SIZE",
    "GL_FACES",
    "LOD_MAPPINGS",
    "WORLD_FROM_GL",
    "level_of_roughness",
    "read_chain",
    "roughness_of_level",
    "world_face_frames",
]
