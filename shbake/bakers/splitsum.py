"""The split-sum baselines (Karis 2013; Silvennoinen et al. 2025 §3.2).

``E(v, n, α) ≈ L̃(ρ, α) · (F0 A0(n·v, α) + (1 − F0) A1(n·v, α))``: a chain of
octahedral maps ``L̃`` (:mod:`shbake.texture.octahedral`) prefiltered with the
GGX lobe under ``n = v = ρ``, one level per GGX width ``α`` of
``config.alphas``, times the DFG table (:mod:`shbake.bakers.dfg`). Level
``k`` has ``max(min_size, top >> k)`` texels per side.

Two prefilters, both from Karis' listing — ``N`` half vectors
importance-sampled from ``D`` (a 2D Fibonacci lattice), ``L = 2(V·H)H − V``,
radiance averaged with weight ``N·L``:

* ``plain`` (the paper's baseline, §5.1): each sample reads one texel of the
  map (``N = 1024``).
* ``filtered`` (engine-grade, as glTF-IBL-Sampler and Filament's cmgen do):
  filtered importance sampling (Křivánek & Colbert 2008) — each sample reads
  the level of the map's solid-angle pyramid (:mod:`shbake.envmap.importance`)
  whose texels match its share of the sphere, ``Ω_s = 1/(N p)`` with
  ``p = D(h)/4`` (``n = v``), one level coarser (``LOD_BIAS``). A sun is then
  spread over the texels of a coarse level instead of landing on a few
  samples: no fireflies.

Shaded by :mod:`shbake.shading.splitsum`.
"""

from dataclasses import asdict, dataclass

import numpy as np

from shbake.bakers.shexp_targets import pyramid_texel
from shbake.brdf.ggx import ggx_d_iso, half_vector_cos2
from shbake.brdf.sampling import tangent_frame
from shbake.conventions import check_samples
from shbake.envmap.importance import latlong_flat, latlong_pyramid, level_offsets, pyramid_levels
from shbake.envmap.layouts import (
    latlong_cell_by_table,
    latlong_cells,
    latlong_texel,
    log2_row_solid_angles,
)
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks, thread_budget
from shbake.reference.ggx import check_alpha
from shbake.resources import check_memory
from shbake.sh.point_sets import fibonacci_square
from shbake.simd import disjoint_arrays, inline_into_callers
from shbake.texture.octahedral import decode as oct_decode

PAPER_ALPHAS = (0.25, 0.36, 0.49, 0.64, 0.81, 1.0)
"""The evaluation's GGX widths (:mod:`shbake.evaluation.probes`): the paper's levels sit at them."""
PREFILTERS = ("plain", "filtered")
LEVEL_SIZE_MIN, LEVEL_SIZE_MAX = 8, 2048
"""Range of the octahedral level sizes (texels per side)."""


@dataclass(frozen=True)
class SplitSumConfig:
    """Mip-chain layout: one level per ``α`` of ``alphas`` from ``top`` texels down to
    ``min_size``; ``samples`` half vectors per texel; ``prefilter`` (module docstring)."""

    top: int = 128
    min_size: int = 32
    alphas: tuple = PAPER_ALPHAS
    samples: int = 1024
    prefilter: str = "plain"

    def __post_init__(self):
        if not (LEVEL_SIZE_MIN <= self.min_size <= self.top <= LEVEL_SIZE_MAX):
            raise ParameterError(
                f"split-sum sizes must satisfy {LEVEL_SIZE_MIN} ≤ min_size ≤ "
                f"top ≤ {LEVEL_SIZE_MAX}, got {self.min_size}, {self.top}"
            )
        a = check_alpha(np.asarray(self.alphas, float).reshape(-1), name="split-sum levels")
        if not 2 <= a.size <= 16 or np.any(np.diff(a) <= 0):
            raise ParameterError("split-sum levels: 2 to 16 increasing GGX widths")
        object.__setattr__(self, "alphas", tuple(float(x) for x in a))
        if self.prefilter not in PREFILTERS:
            raise ParameterError(f"prefilter must be one of {', '.join(PREFILTERS)}")
        check_samples(self.samples)

    @property
    def levels(self) -> int:
        return len(self.alphas)

    @property
    def alpha_range(self) -> tuple[float, float]:
        return self.alphas[0], self.alphas[-1]

    @property
    def sizes(self) -> list[int]:
        return [max(self.min_size, self.top >> k) for k in range(self.levels)]

    def as_dict(self) -> dict:
        return asdict(self) | {"alphas": list(self.alphas)}


@jit
def _lobe_samples(alpha, square, out):
    """``out[:, k] = (cos θ_h, sin θ_h cos φ, sin θ_h sin φ, log2(N D(h)/4))`` of the
    ``k``-th of ``N`` GGX half vectors (width ``α``, in its normal's tangent frame,
    ``n = v``) drawn from ``square[k]``: what every texel of a level shares, computed once
    per level (``D(h)/4`` is the sample's density, ``n = v``; its log picks the
    ``filtered`` prefilter's level, :func:`~shbake.bakers.shexp_targets.pyramid_texel`)."""
    a2 = alpha * alpha
    n = square.shape[0]
    for k in range(n):
        phi = 2.0 * np.pi * square[k, 1]
        u = square[k, 0]
        ct = np.sqrt(half_vector_cos2(a2, u))
        st = np.sqrt(max(0.0, 1.0 - ct * ct))
        out[0, k] = ct
        out[1, k] = st * np.cos(phi)
        out[2, k] = st * np.sin(phi)
        out[3, k] = np.log2(n * (ggx_d_iso(a2, ct) / 4.0))  # D(h) (n·h) / (4 v·h), n = v


@jit
def _reflect(k, lobe, nx, ny, nz, tx, ty, tz, bx, by, bz):
    """``L = 2(V·H)H − V`` and ``N·L`` for ``V = N`` and the ``k``-th half vector of ``lobe``
    (:func:`_lobe_samples`) in the frame ``(t, b, n)``."""
    inline_into_callers()
    ct, hx_, hy_ = lobe[0, k], lobe[1, k], lobe[2, k]
    hx = hx_ * tx + hy_ * bx + ct * nx
    hy = hx_ * ty + hy_ * by + ct * ny
    hz = hx_ * tz + hy_ * bz + ct * nz
    d = 2.0 * ct  # V = N, so V·H = cos θ_h
    lx, ly, lz = d * hx - nx, d * hy - ny, d * hz - nz
    return lx, ly, lz, lx * nx + ly * ny + lz * nz


@jit
def _texel_samples(lobe, nx, ny, nz, tx, ty, tz, bx, by, bz, height, width, cells, filtered,
                   offsets, log2_omega, index, weight):  # fmt: skip
    """``index[k]``, ``weight[k]``: the map texel (flat; the pyramid's for ``filtered``) and
    ``N·L`` of every sample of one texel of a level, its frame ``(t, b, n)``. A sample whose
    cell :func:`latlong_cell_by_table` is not sure of gets index −1. One loop, vectorised
    (no branch; the arrays are disjoint, :func:`disjoint_arrays`)."""
    disjoint_arrays()
    inline_into_callers()
    levels = offsets.shape[0] - 1
    for k in range(lobe.shape[1]):
        lx, ly, lz, nl = _reflect(k, lobe, nx, ny, nz, tx, ty, tz, bx, by, bz)
        r, c, sure = latlong_cell_by_table(lx, ly, lz, height, width, cells)
        if filtered:
            j = pyramid_texel(r, c, lobe[3, k], width, levels, offsets, log2_omega)
        else:
            j = r * width + c
        index[k] = j if sure else -1
        weight[k] = nl


@jit
def _prefilter(size, lobe, pixels, height, width, cells, filtered, offsets, out, b0, b1):
    """Rows ``[b0, b1)`` of a level: per texel, the ``N·L``-weighted mean of the map at the
    lobe's reflected samples, in sample order. Each sample's cell is
    :func:`~shbake.envmap.layouts.latlong_texel`'s: found by :func:`_texel_samples`, or
    where that is not sure, by ``latlong_texel`` itself."""
    n = lobe.shape[1]
    levels = offsets.shape[0] - 1
    log2_omega = log2_row_solid_angles(height, width)
    index = np.empty(n, np.int64)
    weight = np.empty(n)
    for row in range(b0, b1):
        for col in range(size):
            nx, ny, nz = oct_decode((col + 0.5) / size, (row + 0.5) / size)
            (tx, ty, tz), (bx, by, bz) = tangent_frame(nx, ny, nz)
            _texel_samples(lobe, nx, ny, nz, tx, ty, tz, bx, by, bz, height, width, cells,
                           filtered, offsets, log2_omega, index, weight)  # fmt: skip
            acc0 = acc1 = acc2 = 0.0
            wsum = 0.0
            for k in range(n):
                nl = weight[k]
                if nl <= 0.0:
                    continue
                j = index[k]
                if j < 0:
                    lx, ly, lz, _ = _reflect(k, lobe, nx, ny, nz, tx, ty, tz, bx, by, bz)
                    j = latlong_texel(lx, ly, lz, height, width)
                    if filtered:
                        j = pyramid_texel(j // width, j % width, lobe[3, k], width, levels,
                                          offsets, log2_omega)  # fmt: skip
                acc0 += pixels[j, 0] * nl
                acc1 += pixels[j, 1] * nl
                acc2 += pixels[j, 2] * nl
                wsum += nl
            out[row, col, 0] = acc0 / wsum
            out[row, col, 1] = acc1 / wsum
            out[row, col, 2] = acc2 / wsum


LEVEL_TEXEL_BYTES = 36
"""Bytes per texel of a level: the float64 level ``(size, size, 3)`` and its float32 copy."""
MAP_TEXEL_BYTES = 64
"""Bytes per source-map texel: the flat float64 copy and (``filtered``) its pyramid."""
SAMPLE_BYTES = 16
"""Scratch bytes per sample, in each thread: a texel's sample index and ``N·L``
(:func:`_texel_samples`)."""


def chain_memory(config: SplitSumConfig, shape: tuple[int, int]) -> int:
    """Estimated peak bytes of :func:`prefilter_chain` for a map of ``shape``: every level
    is kept (:data:`LEVEL_TEXEL_BYTES` per texel) beside the prepared map, and each thread
    has its scratch (:data:`SAMPLE_BYTES` per sample)."""
    levels = sum(s * s for s in config.sizes) * LEVEL_TEXEL_BYTES
    scratch = config.samples * SAMPLE_BYTES * thread_budget()
    return int(levels + int(shape[0]) * int(shape[1]) * MAP_TEXEL_BYTES + scratch)


def prefilter_chain(pixels, config: SplitSumConfig) -> list[np.ndarray]:
    """The prefiltered octahedral levels, float32 ``(size_k, size_k, 3)`` each. Refused,
    before any level is made, when :func:`chain_memory` exceeds the memory budget."""
    sizes = config.sizes
    check_memory(chain_memory(config, pixels.shape[:2]),
                 f"a split-sum chain of {len(sizes)} levels from {sizes[0]}x{sizes[0]} "
                 f"to {sizes[-1]}x{sizes[-1]}")  # fmt: skip
    flat, h, w = latlong_flat(pixels)
    if config.prefilter == "filtered":
        levels = pyramid_levels((h, w))
        offsets = level_offsets((h, w), levels)
        flat = latlong_pyramid(flat, (h, w), levels)
    else:
        offsets = level_offsets((h, w), 1)
    cells = latlong_cells(h, w)
    square = fibonacci_square(config.samples)
    lobe = np.empty((4, square.shape[0]))
    out_levels = []
    for size, a in zip(config.sizes, config.alphas, strict=True):
        _lobe_samples(float(a), square, lobe)
        out = np.empty((size, size, 3))
        run_blocks(_prefilter, size, size * size * square.shape[0] * 60.0, size, lobe, flat,
                   h, w, cells, config.prefilter == "filtered", offsets, out)  # fmt: skip
        out_levels.append(out.astype(np.float32))
    return out_levels
