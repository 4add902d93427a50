"""Where a lat-long map's light is: luminous weights, a sampling distribution, its
brightest texels, and the solid-angle pyramid of filtered importance sampling.

Luminous weight of texel ``j``: ``max(Y(L_j), 0) Ω_j`` (Rec.709 luminance ``Y``,
exact cell solid angle ``Ω_j``, SPEC §3). The pyramid halves the map while
its height is even and at least 8 rows, each texel the solid-angle-weighted
mean of its 2×2 children (Křivánek & Colbert 2008 sample a level whose texel
matches a sample's share of the sphere).
"""

import numpy as np

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap.layouts import latlong_solid_angles, latlong_texel_point, row_solid_angle
from shbake.errors import ParameterError
from shbake.jit import jit

BRIGHT_TEXELS = 64
"""Point lights taken from a map: at most this many texels, the brightest ..."""
BRIGHT_SHARE = 1e-4
"""... among those holding more than this share of the map's luminous weight."""
PYRAMID_LEVELS = 6


def luminous_weight(flat: np.ndarray, height: int, width: int):
    """Luminance × solid angle per texel (negative luminance counts as 0), and the
    solid angles; both flat float64 ``(H·W,)``. ``flat`` is ``(H·W, 3)`` radiance."""
    omega = latlong_solid_angles(height, width).reshape(-1)
    return np.maximum(flat.astype(np.float64) @ REC709_LUMINANCE, 0.0) * omega, omega


def light_distribution(flat: np.ndarray, height: int, width: int):
    """Texel CDF ∝ luminous weight and the matching density per steradian.

    A black map has an empty CDF (then only the BRDF is sampled).
    """
    weight, omega = luminous_weight(flat, height, width)
    total = weight.sum()
    if not total > 0.0:
        return np.zeros(0), np.zeros(flat.shape[0])
    cdf = np.cumsum(weight) / total
    cdf[-1] = 1.0
    return cdf, weight / total / omega


def bright_texels(flat: np.ndarray, height: int, width: int):
    """The map's brightest texels as point lights: flat indices, world directions (texel
    centres) and ``L Ω`` (:data:`BRIGHT_TEXELS`, :data:`BRIGHT_SHARE`)."""
    weight, omega = luminous_weight(flat, height, width)
    total = weight.sum()
    if not total > 0.0:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    top = np.flatnonzero(weight > BRIGHT_SHARE * total)
    if top.size > BRIGHT_TEXELS:  # the brightest; ties broken by index, so deterministic
        order = np.lexsort((top, -weight[top]))[:BRIGHT_TEXELS]
        top = np.sort(top[order])
    dirs = np.array([latlong_texel_point(j, 0.5, 0.5, height, width) for j in top]).reshape(-1, 3)
    return top, dirs, flat[top].astype(np.float64) * omega[top, None]


@jit
def _pair_sum(x, y):
    """``x + y`` of two float32 texels as a float64: their float32 sum where that is finite
    (the rounding the pyramid has always had), else their float64 sum — two texels near the
    float32 limit (3.4e38, radiance) overflow float32, never float64."""
    s = x + y
    if np.isinf(s):
        return np.float64(x) + np.float64(y)
    return np.float64(s)


@jit
def _downsample(src, height, width, dst):
    """One pyramid step: 2×2 texels averaged with their solid angles (a mean of finite
    texels, finite)."""
    for i in range(height // 2):
        w0 = row_solid_angle(2 * i, height, width)
        w1 = row_solid_angle(2 * i + 1, height, width)
        s = 0.5 / (w0 + w1)
        for j in range(width // 2):
            a, b = (2 * i) * width + 2 * j, (2 * i + 1) * width + 2 * j
            for c in range(3):
                dst[i * (width // 2) + j, c] = s * (
                    w0 * _pair_sum(src[a, c], src[a + 1, c])
                    + w1 * _pair_sum(src[b, c], src[b + 1, c])
                )


def pyramid_levels(shape: tuple[int, int]) -> int:
    """Levels of the lat-long pyramid of a map: halve while even and at least 8 rows."""
    h = shape[0]
    levels = 1
    while levels < PYRAMID_LEVELS and h % 2 == 0 and h // 2 >= 8:
        h //= 2
        levels += 1
    return levels


def level_offsets(shape: tuple[int, int], levels: int) -> np.ndarray:
    """Flat start of each pyramid level (and the total), ``(levels + 1,)`` int64."""
    h, w = shape
    sizes = [(h >> k) * (w >> k) for k in range(levels)]
    return np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)


def latlong_pyramid(flat: np.ndarray, shape: tuple[int, int], levels: int) -> np.ndarray:
    """The map and its solid-angle-weighted 2×2 reductions, stacked flat ``(Σ texels, 3)``."""
    offsets = level_offsets(shape, levels)
    out = np.empty((offsets[-1], 3), dtype=np.float32)
    out[: offsets[1]] = flat
    h, w = shape
    for k in range(levels - 1):
        _downsample(
            out[offsets[k] : offsets[k + 1]], h >> k, w >> k, out[offsets[k + 1] : offsets[k + 2]]
        )
    return out


def latlong_flat(pixels: np.ndarray) -> tuple[np.ndarray, int, int]:
    """A lat-long ``(H, 2H, 3)`` map as contiguous float32 ``(H·W, 3)`` and its shape."""
    if pixels.ndim != 3 or pixels.shape[2] != 3 or pixels.shape[1] != 2 * pixels.shape[0]:
        raise ParameterError("expected a lat-long (2:1) RGB map")
    h, w = pixels.shape[:2]
    return np.ascontiguousarray(pixels.reshape(-1, 3), dtype=np.float32), h, w
