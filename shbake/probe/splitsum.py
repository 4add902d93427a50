"""The split-sum baseline (Karis 2013; Silvennoinen et al. 2025 §3.2).

``E(v, n, r) ≈ L̃(ρ, r) · (F0 A0(n·v, r) + (1 − F0) A1(n·v, r))``: a mip chain
of octahedral maps ``L̃`` prefiltered with the GGX lobe under ``n = v = ρ``,
each level at one roughness, times the DFG table of
:mod:`shbake.probe.albedo_table`. Prefiltering follows Karis' listing:
``N`` half vectors importance-sampled from ``D`` (a 2D Fibonacci lattice),
``L = 2(V·H)H − V``, radiance averaged with weight ``N·L``.

Octahedral map (Cigolle et al. 2014) about +Y (the up axis): for unit ``d``,
``p = (d_x, d_z)/(|d_x|+|d_y|+|d_z|)``, folded for ``d_y < 0`` as
``p ← ((1−|p_z|) sign p_x, (1−|p_x|) sign p_z)``; texture ``(u, w) = (p+1)/2``,
texel centres, bilinear fetch clamped at the edges. Levels: roughness
``linspace(r_min, r_max, levels)``, size ``max(min_size, top >> k)``; between
levels the fetch interpolates linearly in roughness.
"""

from dataclasses import asdict, dataclass

import numba
import numpy as np

from shbake.brdf.sampling import tangent_frame
from shbake.errors import ParameterError
from shbake.jit import jit, pjit
from shbake.probe.albedo_table import table_lookup
from shbake.probe.ggx_integrals import (
    check_roughness,
    check_samples,
    fibonacci_square,
    ggx_alpha,
    latlong_texel,
)


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


@jit
def oct_decode(u, w):
    """Unit direction of octahedral texture coordinates ``(u, w) ∈ [0, 1]²``."""
    px, pz = 2.0 * u - 1.0, 2.0 * w - 1.0
    dy = 1.0 - abs(px) - abs(pz)
    dx, dz = px, pz
    if dy < 0.0:
        dx = (1.0 - abs(pz)) * (1.0 if px >= 0.0 else -1.0)
        dz = (1.0 - abs(px)) * (1.0 if pz >= 0.0 else -1.0)
    n = np.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / n, dy / n, dz / n


@jit
def oct_encode(dx, dy, dz):
    """Octahedral texture coordinates ``(u, w)`` of a unit direction."""
    s = abs(dx) + abs(dy) + abs(dz)
    px, pz = dx / s, dz / s
    if dy < 0.0:
        px, pz = (
            (1.0 - abs(pz)) * (1.0 if px >= 0.0 else -1.0),
            (1.0 - abs(px)) * (1.0 if pz >= 0.0 else -1.0),
        )
    return 0.5 * (px + 1.0), 0.5 * (pz + 1.0)


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


@jit
def _fetch(level, dx, dy, dz, c):
    size = level.shape[0]
    u, w = oct_encode(dx, dy, dz)
    x = min(max(u * size - 0.5, 0.0), size - 1.0)
    y = min(max(w * size - 0.5, 0.0), size - 1.0)
    i = min(int(y), size - 2)
    j = min(int(x), size - 2)
    fy, fx = y - i, x - j
    return (1 - fy) * ((1 - fx) * level[i, j, c] + fx * level[i, j + 1, c]) + fy * (
        (1 - fx) * level[i + 1, j, c] + fx * level[i + 1, j + 1, c]
    )


@pjit
def _evaluate(views, normals, roughness, f0, flat_levels, offsets, sizes, r_levels, table, out):
    n_levels = sizes.shape[0]
    for k in numba.prange(views.shape[0]):
        vx, vy, vz = views[k, 0], views[k, 1], views[k, 2]
        nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
        nv = nx * vx + ny * vy + nz * vz
        rx, ry, rz = 2 * nv * nx - vx, 2 * nv * ny - vy, 2 * nv * nz - vz
        r = roughness[k]
        x = (r - r_levels[0]) / (r_levels[n_levels - 1] - r_levels[0]) * (n_levels - 1)
        x = min(max(x, 0.0), n_levels - 1.0)
        i0 = min(int(x), n_levels - 2)
        t = x - i0
        a0, a1 = table_lookup(table, nv, r)
        lv0 = flat_levels[offsets[i0] : offsets[i0 + 1]].reshape((sizes[i0], sizes[i0], 3))
        lv1 = flat_levels[offsets[i0 + 1] : offsets[i0 + 2]].reshape(
            (sizes[i0 + 1], sizes[i0 + 1], 3)
        )
        for c in range(3):
            pre = (1 - t) * _fetch(lv0, rx, ry, rz, c) + t * _fetch(lv1, rx, ry, rz, c)
            out[k, c] = pre * (f0[c] * a0 + (1.0 - f0[c]) * a1)


def evaluate_splitsum(levels, level_roughness, table, views, normals, roughness, f0=(1.0,) * 3):
    """Outgoing radiance ``(T, 3)`` of a split-sum probe at world ``(v, n, r)``."""
    sizes = np.array([lv.shape[0] for lv in levels], dtype=np.int64)
    flat = np.concatenate([np.asarray(lv, float).reshape(-1) for lv in levels])
    offsets = np.concatenate([[0], np.cumsum(sizes * sizes * 3)]).astype(np.int64)
    v = np.ascontiguousarray(np.asarray(views, float).reshape(-1, 3))
    n = np.ascontiguousarray(np.asarray(normals, float).reshape(-1, 3))
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(roughness, float), (v.shape[0],)))
    out = np.empty((v.shape[0], 3))
    f0 = np.broadcast_to(np.asarray(f0, float), (3,)).copy()
    _evaluate(
        v, n, r, f0, flat, offsets, sizes, np.asarray(level_roughness, float),
        np.asarray(table, float), out,
    )  # fmt: skip
    return out
