"""The split-sum baseline prefilter (Karis 2013; Silvennoinen et al. 2025 §3.2).

``E(v, n, r) ≈ L̃(ρ, r) · (F0 A0(n·v, r) + (1 − F0) A1(n·v, r))``: a chain of
octahedral maps ``L̃`` (:mod:`shbake.texture.octahedral`) prefiltered with the
GGX lobe under ``n = v = ρ``, each level at one roughness, times the DFG table
(:mod:`shbake.bakers.dfg`). Prefiltering follows Karis' listing: ``N`` half
vectors importance-sampled from ``D`` (a 2D Fibonacci lattice),
``L = 2(V·H)H − V``, radiance averaged with weight ``N·L``. Levels: roughness
``linspace(r_min, r_max, levels)``, size ``max(min_size, top >> k)``. Shaded by
:mod:`shbake.shading.splitsum`.
"""

from dataclasses import asdict, dataclass

import numba
import numpy as np

from shbake.brdf.sampling import tangent_frame
from shbake.conventions import check_roughness, check_samples, ggx_alpha
from shbake.envmap.layouts import latlong_texel
from shbake.errors import ParameterError
from shbake.jit import pjit
from shbake.sh.point_sets import fibonacci_square
from shbake.texture.octahedral import decode as oct_decode


@dataclass(frozen=True)
class SplitSumConfig:
    """Mip-chain layout: ``levels`` roughness levels from ``top`` texels down to ``min_size``."""

    top: int = 128
    min_size: int = 32
    levels: int = 5
    roughness_min: float = 0.2
    roughness_max: float = 1.0
    samples: int = 1024

    def __post_init__(self):
        if not (8 <= self.min_size <= self.top <= 2048):
            raise ParameterError("split-sum sizes must satisfy 8 ≤ min_size ≤ top ≤ 2048")
        if not 2 <= self.levels <= 16:
            raise ParameterError("split-sum levels must be in [2, 16]")
        check_roughness([self.roughness_min, self.roughness_max], 0.05, 1.0, "roughness range")
        if self.roughness_min >= self.roughness_max:
            raise ParameterError("roughness range must be lo < hi")
        check_samples(self.samples)

    @property
    def roughness(self) -> np.ndarray:
        return np.linspace(self.roughness_min, self.roughness_max, self.levels)

    @property
    def sizes(self) -> list[int]:
        return [max(self.min_size, self.top >> k) for k in range(self.levels)]

    def as_dict(self) -> dict:
        return asdict(self)


@pjit
def _prefilter(size, alpha, square, pixels, height, width, out):
    n = square.shape[0]
    a2 = alpha * alpha
    for row in numba.prange(size):
        for col in range(size):
            nx, ny, nz = oct_decode((col + 0.5) / size, (row + 0.5) / size)
            (tx, ty, tz), (bx, by, bz) = tangent_frame(nx, ny, nz)
            acc0 = acc1 = acc2 = 0.0
            wsum = 0.0
            for k in range(n):
                phi = 2.0 * np.pi * square[k, 1]
                u = square[k, 0]
                ct = np.sqrt((1.0 - u) / (1.0 + (a2 - 1.0) * u))
                st = np.sqrt(max(0.0, 1.0 - ct * ct))
                hx_, hy_ = st * np.cos(phi), st * np.sin(phi)
                hx = hx_ * tx + hy_ * bx + ct * nx
                hy = hx_ * ty + hy_ * by + ct * ny
                hz = hx_ * tz + hy_ * bz + ct * nz
                d = 2.0 * ct  # V = N, so V·H = cos θ_h
                lx, ly, lz = d * hx - nx, d * hy - ny, d * hz - nz
                nl = lx * nx + ly * ny + lz * nz
                if nl <= 0.0:
                    continue
                j = latlong_texel(lx, ly, lz, height, width)
                acc0 += pixels[j, 0] * nl
                acc1 += pixels[j, 1] * nl
                acc2 += pixels[j, 2] * nl
                wsum += nl
            out[row, col, 0] = acc0 / wsum
            out[row, col, 1] = acc1 / wsum
            out[row, col, 2] = acc2 / wsum


def prefilter_chain(pixels, config: SplitSumConfig) -> list[np.ndarray]:
    """The prefiltered octahedral levels, float32 ``(size_k, size_k, 3)`` each."""
    if pixels.ndim != 3 or pixels.shape[1] != 2 * pixels.shape[0]:
        raise ParameterError("split-sum prefiltering takes a lat-long (2:1) RGB map")
    h, w = pixels.shape[:2]
    flat = np.ascontiguousarray(pixels.reshape(-1, 3), dtype=np.float32)
    square = fibonacci_square(config.samples)
    levels = []
    for size, r in zip(config.sizes, config.roughness, strict=True):
        out = np.empty((size, size, 3))
        _prefilter(size, float(ggx_alpha(r)), square, flat, h, w, out)
        levels.append(out.astype(np.float32))
    return levels
