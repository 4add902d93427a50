"""GGX prefiltered cube levels with filtered importance sampling (split-sum radiance).

The levels of the chains :func:`shbake.bakers.cube_chain.prefilter_chain` assembles. Level
``i`` of a chain of ``n`` levels (sizes ``size >> i``, at least the
stated floor) holds, for every texel direction ``N``, the split-sum
prefiltered radiance of Karis 2013 (eq. 4, ``N = V = R``)::

    P(N, α) = ∫ L(l) D(h) (N·l) dl / ∫ D(h) (N·l) dl        (h = normalize(N + l))

estimated with ``K`` GGX half-vector samples (Walter et al. 2007 eq. 35–36,
``D``/``Λ`` from :mod:`shbake.brdf.ggx`) and **filtered importance sampling**
(Křivánek & Colbert 2008, GPU Gems 3 ch. 20, eq. 20-2/20-3): each sample reads
the source cube's mip pyramid at ``lod = ½ log2(Ω_s / Ω_p) + 1`` where
``Ω_s = 1 / (K p(l))`` is the sample's solid angle, ``p(l) = D(h)/4`` its
density (``N = V``) and ``Ω_p = 4π / (6 N0²)`` a level-0 texel. That is what
glTF-IBL-Sampler (``lib/source/shaders/filter.frag``, ``computeLod``) and
Filament (``libs/ibl/src/CubemapIBL.cpp``, ``roughnessFilter``) do; it removes
the bright specks a sun gives at ``α`` 0.2–0.4 with point sampling.

FIS blurs each sample over its footprint, which for a compact bright source (a lamp or
sun of a few texels far above its surroundings) is far wider than the source: studio's
lamps (up to 3482 against a 0.1–1 room) came out 5.7 % median / 60 % p95 from brute force
at 32², r 0.29. So the source is split first (:func:`split_hot_texels`): each map texel
brighter than :data:`HOT_CONTRAST` × the map's median radiance is clamped to that value in
the map the pyramid is built from, and its excess is summed **exactly** into every output
texel (``ΔL D(h) (N·l) Ω`` over the excess texels, divided by the lobe's closed-form
normalisation :func:`lobe_normalization`), the quadrature brute force uses; FIS filters
only the clamped remainder.

Level 0 is the mirror map (``α = 0``): the source resampled at :func:`mirror_supersample`
sub-texels, no lobe. A level of at most ``FIT_MAX_SIZE``² faces holds, instead of its
values at its texel centres, the texel values whose GPU bilinear read best fits the level at
2 × 2 points per texel, each with half the level's samples (:func:`fit_bilinear`): an engine
reads between the centres. (An engine with a roughness floor also gets its sharp levels
refitted to its blend between levels: :mod:`shbake.bakers.lod_blend`.)
The roughness of each level (``mapping``) and the cube's faces are the engines' and
live in :mod:`shbake.format.exports.cube_chain`; texel solid angles are the exact ones of
:func:`shbake.envmap.layouts.cube_face_solid_angles` (the same grid on every face).
Every output texel is computed at its own direction, so faces agree along their shared
edges (no seam).
"""

import math
from typing import NamedTuple

import numpy as np

from shbake.brdf.ggx import ggx_d, ggx_d_iso, half_vector_cos2
from shbake.conventions import REC709_LUMINANCE
from shbake.envmap.environment import Environment
from shbake.envmap.layouts import cube_face_solid_angles
from shbake.errors import ParameterError
from shbake.format.exports.cube_chain import (
    world_face_frames,
)
from shbake.jit import jit, run_blocks
from shbake.reference.prefiltered import reference_radiance
from shbake.texture.bilinear import axis, bilinear_latlong, blend
from shbake.texture.cube import (
    MAX_TAPS,
    cube_bilinear_taps,
    cube_face_st,
    nearest_texels,
    texel_coordinate,
)
from shbake.texture.cube import cube_directions as texel_directions

DEFAULT_SAMPLES = 512


def cube_directions(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit world directions ``(6, size, size, 3)`` and exact solid angles ``(size, size)``."""
    d = texel_directions(size, world_face_frames())
    omega = cube_face_solid_angles(size)  # exact, the same grid on every face
    return d, omega


# ---------------------------------------------------------------- source sampling


@jit
def _sub_coordinate(i, k, size, j):
    """Face coordinate in [-1, 1] of sub-texel ``j`` (of ``k``) of texel ``i`` along an axis."""
    return 2.0 * ((i + (j + 0.5) / k) / size) - 1.0


@jit
def _face_direction(frames, rot, face, s, t):
    """Unit direction at face coordinates ``(s, t)`` of face ``face`` (faces ``frames``),
    turned by ``rot`` (row vector ``d R``)."""
    F = frames[face]
    x = F[0, 0] * s + F[0, 1] * t + F[0, 2]
    y = F[1, 0] * s + F[1, 1] * t + F[1, 2]
    z = F[2, 0] * s + F[2, 1] * t + F[2, 2]
    n = math.sqrt(x * x + y * y + z * z)
    x, y, z = x / n, y / n, z / n
    return (
        x * rot[0, 0] + y * rot[1, 0] + z * rot[2, 0],
        x * rot[0, 1] + y * rot[1, 1] + z * rot[2, 1],
        x * rot[0, 2] + y * rot[1, 2] + z * rot[2, 2],
    )


@jit
def _sub_directions(frames, rot, size, k, out, b0, b1):
    # out (6 size², k², 3): every sub-texel direction (row-major k × k grid) of texels b0 … b1
    for m in range(b0, b1):
        face, rc = m // (size * size), m % (size * size)
        for q in range(k * k):
            s = _sub_coordinate(rc % size, k, size, q % k)
            t = _sub_coordinate(rc // size, k, size, q // k)
            out[m, q, 0], out[m, q, 1], out[m, q, 2] = _face_direction(frames, rot, face, s, t)


@jit
def _resample_latlong(img, frames, rot, size, k, out, b0, b1):
    # out (6 size², 3): box average of the k² bilinear lat-long fetches of each texel, in the
    # row-major order of _sub_directions; a texel's k column and k row coordinates made once
    tmp = np.zeros(3)
    ss = np.empty(k)
    ts = np.empty(k)
    for m in range(b0, b1):
        face, rc = m // (size * size), m % (size * size)
        for j in range(k):
            ss[j] = _sub_coordinate(rc % size, k, size, j)
            ts[j] = _sub_coordinate(rc // size, k, size, j)
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        for q in range(k * k):
            dx, dy, dz = _face_direction(frames, rot, face, ss[q % k], ts[q // k])
            u = math.atan2(dx, -dz) / (2.0 * math.pi)
            u = u - math.floor(u)
            v = math.acos(min(1.0, max(-1.0, dy))) / math.pi
            bilinear_latlong(img, u, v, tmp)
            acc0 += tmp[0]
            acc1 += tmp[1]
            acc2 += tmp[2]
        out[m, 0] = acc0 / (k * k)
        out[m, 1] = acc1 / (k * k)
        out[m, 2] = acc2 / (k * k)


SUPERSAMPLE = 4
"""Sub-texels per side of a mirror-cube texel (:func:`mirror_cube`)."""


def mirror_cube(
    env: Environment, size: int, supersample: int = SUPERSAMPLE, rotation: np.ndarray | None = None
) -> np.ndarray:
    """The mirror (``α = 0``) cube map, ``(6, size, size, 3)`` float64.

    ``rotation`` (3×3, target ← world): the cube is built in the target frame,
    its texel ``d_t`` showing the map at world direction ``Rᵀ d_t``.

    Each texel is the mean of ``supersample²`` bilinear lat-long fetches
    (:mod:`shbake.texture.bilinear`, SPEC §3 ``u, v``) over the texel cell, or for cube
    inputs the source texels whose centres fall in it (nearest face texel).
    """
    if size < 1 or size & (size - 1):
        raise ParameterError(f"cube size must be a power of two, got {size}")
    k = int(supersample)
    rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    frames = world_face_frames()
    texels = 6 * size * size
    out = np.empty((texels, 3))
    if env.layout == "latlong":
        run_blocks(_resample_latlong, texels, texels * k * k * 60.0,
                   env.pixels.astype(np.float64), frames, rot, size, k, out)  # fmt: skip
    else:
        d = np.empty((texels, k * k, 3))
        run_blocks(_sub_directions, texels, texels * k * k * 20.0, frames, rot, size, k, d)
        out[:] = _nearest_cube_input(env, d).mean(axis=1)
    return out.reshape(6, size, size, 3)


def mirror_supersample(env: Environment, size: int) -> int:
    """Sub-texels per side that a mirror level of ``size``² faces needs to see every texel of
    ``env``: ``⌈W / 4 size⌉`` for a lat-long map ``W`` wide (a face spans a quarter of the
    equator), ``⌈N / size⌉`` for a cube of ``N``² faces; 1 when the cube already samples the
    map more finely than its texels. A texel averages more sub-texels than that only by
    blurring the map: a mirror read bilinearly from 256² faces of a 512×256 map is 15.7 %
    from the map read bilinearly at the 95th percentile of 40 000 directions on forest with
    1 sub-texel, 20.1 % with 4×4 and 20.3 % with the 8×8 of a 512² cube halved."""
    if env.layout == "latlong":
        across = env.pixels.shape[1] / 4.0
    else:
        across = env.pixels.shape[1]
    return max(1, math.ceil(across / size))


def _nearest_cube_input(env: Environment, d: np.ndarray) -> np.ndarray:
    """Radiance of a cube-layout environment at directions ``d`` (nearest texel)."""
    if env.layout != "cube-strip":
        raise ParameterError("cube prefilter reads lat-long or cube-strip maps")
    n = env.pixels.shape[1]
    face, i, j = nearest_texels(d, n)
    return env.pixels[face * n + i, j].astype(np.float64)


def downsample_cube(cube: np.ndarray) -> np.ndarray:
    """Next coarser level: solid-angle weighted mean of each 2×2 block."""
    n = cube.shape[1]
    omega = cube_face_solid_angles(n)
    w = omega[None, :, :, None]
    num = (cube * w).reshape(6, n // 2, 2, n // 2, 2, 3).sum(axis=(2, 4))
    den = w.reshape(1, n // 2, 2, n // 2, 2, 1).sum(axis=(2, 4))
    return num / den


def cube_pyramid(cube: np.ndarray) -> list[np.ndarray]:
    """Box mip pyramid of a cube map down to 1×1 (the FIS source)."""
    levels = [cube]
    while levels[-1].shape[1] > 1:
        levels.append(downsample_cube(levels[-1]))
    return levels


# ---------------------------------------------------------------- the filter


@jit
def _fetch_packed(packed, offset, n, face, s, t, out):
    """Bilinear fetch (clamp-to-edge within the face) at face coordinates ``(s, t)`` of the
    ``n``² level starting at row ``offset`` of ``packed`` (:func:`_packed_pyramid`)."""
    i0, i1, fy = axis(texel_coordinate(t, n), n)
    j0, j1, fx = axis(texel_coordinate(s, n), n)
    row0 = offset + (face * n + i0) * n
    row1 = offset + (face * n + i1) * n
    for c in range(3):
        out[c] = blend(packed[row0 + j0, c], packed[row0 + j1, c], packed[row1 + j0, c],
                       packed[row1 + j1, c], fy, fx)  # fmt: skip


def _packed_pyramid(pyramid: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The levels of ``pyramid`` as rows of one ``(Σ 6 n², 3)`` array, with each level's first
    row and edge ``n`` (one array the kernel indexes, not a list of arrays)."""
    sizes = np.array([p.shape[1] for p in pyramid], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(6 * sizes * sizes)[:-1]]).astype(np.int64)
    return np.concatenate([p.reshape(-1, 3) for p in pyramid]), offsets, sizes


@jit
def _hammersley(i, n):
    b = i
    r = 0.0
    f = 0.5
    while b > 0:
        r += f * (b & 1)
        b >>= 1
        f *= 0.5
    return (i + 0.5) / n, r


@jit
def _sample_table(alpha, samples, omega_p, n_levels, use_fis, table):
    """Row ``q`` of ``table``: sample ``q``'s light direction in the texel's frame (``n = +z``),
    its source levels ``i0``, ``i1`` and blend ``f``; the same for every texel of a level.
    Returns the number of rows (samples below the horizon are left out)."""
    a2 = alpha * alpha
    m = 0
    for q in range(samples):
        u1, u2 = _hammersley(q, samples)
        cos2 = half_vector_cos2(a2, u1)
        ct = math.sqrt(cos2)
        st = math.sqrt(max(0.0, 1.0 - cos2))
        ph = 2.0 * math.pi * u2
        hx, hy, hz = st * math.cos(ph), st * math.sin(ph), ct
        # l = 2 (n.h) h - n in the local frame (n = +z)
        lz = 2.0 * hz * hz - 1.0
        if lz <= 0.0:
            continue
        if use_fis:
            pdf = ggx_d(alpha, alpha, hx, hy, hz) * 0.25
            omega_s = 1.0 / (samples * pdf)
            lod = 0.5 * math.log2(omega_s / omega_p) + 1.0
            lod = min(max(lod, 0.0), n_levels - 1.0)
        else:
            lod = 0.0
        i0 = int(lod)
        table[m, 0] = 2.0 * hz * hx
        table[m, 1] = 2.0 * hz * hy
        table[m, 2] = lz
        table[m, 3] = i0
        table[m, 4] = min(i0 + 1, n_levels - 1)
        table[m, 5] = lod - i0
        m += 1
    return m


@jit
def _prefilter_fis(packed, offsets, sizes, wf, dirs, table, out, b0, b1):
    lo = np.zeros(3)
    hi = np.zeros(3)
    for k in range(b0, b1):
        nx, ny, nz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        # tangent frame (Frisvad-style, branchless enough)
        if abs(nz) < 0.999:
            tx, ty, tz = -ny, nx, 0.0
        else:
            tx, ty, tz = 0.0, -nz, ny
        tn = math.sqrt(tx * tx + ty * ty + tz * tz)
        tx, ty, tz = tx / tn, ty / tn, tz / tn
        bx, by, bz = ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        wsum = 0.0
        for q in range(table.shape[0]):
            lx, ly, lz = table[q, 0], table[q, 1], table[q, 2]
            wx = lx * tx + ly * bx + lz * nx
            wy = lx * ty + ly * by + lz * ny
            wz = lx * tz + ly * bz + lz * nz
            face, s, t = cube_face_st(wf, wx, wy, wz)
            l0, l1, f = int(table[q, 3]), int(table[q, 4]), table[q, 5]
            _fetch_packed(packed, offsets[l0], sizes[l0], face, s, t, lo)
            _fetch_packed(packed, offsets[l1], sizes[l1], face, s, t, hi)
            acc0 += lz * ((1.0 - f) * lo[0] + f * hi[0])
            acc1 += lz * ((1.0 - f) * lo[1] + f * hi[1])
            acc2 += lz * ((1.0 - f) * lo[2] + f * hi[2])
            wsum += lz
        out[k, 0] = acc0 / wsum
        out[k, 1] = acc1 / wsum
        out[k, 2] = acc2 / wsum


HOT_CONTRAST = 100.0
"""A map texel brighter (luminance) than this × the map's median radiance is a compact
bright source's (:func:`split_hot_texels`). Measured on the default three.js/Filament chain
(256² to 4², 512·2^(i−1) samples), level 3 (32², r 0.29) against brute force, median / p95:
studio without the split 5.7 % / 60 %, with it 0.08 % / 1.9 % (3642 excess texels);
esplanade (its sun) 0.79 % / 8.4 % → 0.12 % / 0.77 % (175). city has none; forest 371,
night 30, sunset 5 (their levels move by < 0.1 %). The contrast trades accuracy for the
exact sum's cost (studio, level 3, a plain texel median in the sweep): 1000× 0.32 % / 15 %
(1420 texels), 100× 0.08 % / 2.5 % (3484), 20× 0.04 % / 0.75 % (39 096, +11 s CPU)."""

HOT_TEXELS_MAX = 4096
"""Most excess texels summed exactly: beyond it the threshold rises to the
(``HOT_TEXELS_MAX`` + 1)-th brightest texel. The exact sum costs 2 ns per excess texel and
output texel (2-core machine): at most ≈ 1.1 s CPU for the default 256² chain's levels 1 on.
A compact source has few texels; a wider bright region keeps its texels in the FIS map,
whose footprint blur such a region survives."""


class HotTexels(NamedTuple):
    """The excess radiance of a map's compact bright sources (:func:`split_hot_texels`)."""

    dirs: np.ndarray
    """``(m, 3)`` unit directions of the texel centres, in the cube's (target) frame."""
    solid_angles: np.ndarray
    """``(m,)`` exact texel solid angles (sr)."""
    excess: np.ndarray
    """``(m, 3)`` radiance above the clamped value left in the map."""


def split_hot_texels(
    env: Environment, rotation: np.ndarray | None = None
) -> tuple[Environment, HotTexels]:
    """``env`` split into a map whose texels' luminance is at most ``T`` (a hotter texel
    scaled down to ``T``, its colour kept) and the excess of those texels, ``T`` =
    :data:`HOT_CONTRAST` × the solid-angle-weighted median luminance of the map (raised to
    keep at most :data:`HOT_TEXELS_MAX` texels). The two add up to ``env`` exactly (float64).
    ``rotation``: target ← world (:func:`mirror_cube`), applied to the excess directions."""
    dirs, omega, valid = env.texels()
    pixels = env.pixels.astype(np.float64)
    lum = pixels @ REC709_LUMINANCE
    y, w = lum[valid], omega[valid]
    order = np.argsort(y, kind="stable")
    cum = np.cumsum(w[order])
    threshold = HOT_CONTRAST * max(0.0, float(y[order][np.searchsorted(cum, 0.5 * cum[-1])]))
    if np.count_nonzero(y > threshold) > HOT_TEXELS_MAX:
        threshold = float(np.partition(y, -(HOT_TEXELS_MAX + 1))[-(HOT_TEXELS_MAX + 1)])
    hot = valid & (lum > threshold)
    rest = pixels.copy()
    rest[hot] *= (threshold / lum[hot])[:, None]
    rest = rest.astype(env.pixels.dtype)
    excess = pixels[hot] - rest[hot].astype(np.float64)
    rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    hot_texels = HotTexels(np.ascontiguousarray(dirs[hot] @ rot.T), omega[hot], excess)
    return Environment(rest, env.layout, env.meta), hot_texels


def lobe_normalization(alpha: float) -> float:
    """``W(α) = ∫ D(h) (N·l) dl`` over ``N·l > 0`` (sr⁻¹·sr, dimensionless) for ``N = V``:
    with ``x = (N·h)²``, ``dl = 4 (N·h) dh`` and ``N·l = 2x − 1``,
    ``W = 4α² ∫_{½}^{1} (2x − 1) / (1 − (1 − α²) x)² dx
    = 4 (t − 2a ln(1 + t/2a)) / t²`` (``a = α²``, ``t = 1 − a``); ``W → 4`` as ``α → 0``,
    ``W(1) = 1``. Near ``α = 1`` (``s = t/2a < 10⁻²``) the series
    ``(2/a) Σ (−s)^k / (k + 2)``, which the logarithm would lose to cancellation.

    >>> round(lobe_normalization(1.0), 12), round(lobe_normalization(1e-4), 4)
    (1.0, 4.0)
    """
    a = alpha * alpha
    t = 1.0 - a
    s = t / (2.0 * a)
    if s < 1e-2:
        return 2.0 / a * sum((-s) ** k / (k + 2) for k in range(8))
    return 4.0 * (t - 2.0 * a * math.log1p(s)) / (t * t)


@jit
def _add_hot_texels(hot_dirs, hot_omega, hot_excess, dirs, alpha, inv_norm, out, b0, b1):
    """``out[k] += Σ ΔL D(h) (N·l) Ω / W`` over the excess texels (``inv_norm = 1/W``),
    ``D`` at ``N·h = sqrt((1 + N·l)/2)`` as in :func:`_reference_kernel`."""
    a2 = alpha * alpha
    for k in range(b0, b1):
        nx, ny, nz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        for q in range(hot_dirs.shape[0]):
            nl = nx * hot_dirs[q, 0] + ny * hot_dirs[q, 1] + nz * hot_dirs[q, 2]
            if nl <= 0.0:
                continue
            w = ggx_d_iso(a2, math.sqrt(0.5 * (1.0 + nl))) * nl * hot_omega[q]
            acc0 += w * hot_excess[q, 0]
            acc1 += w * hot_excess[q, 1]
            acc2 += w * hot_excess[q, 2]
        out[k, 0] += acc0 * inv_norm
        out[k, 1] += acc1 * inv_norm
        out[k, 2] += acc2 * inv_norm


def prefilter_level(
    pyramid: list[np.ndarray],
    size: int,
    alpha: float,
    samples: int = DEFAULT_SAMPLES,
    fis: bool = True,
    hot: HotTexels | None = None,
) -> np.ndarray:
    """One prefiltered cube ``(6, size, size, 3)`` at GGX ``alpha`` from a source pyramid:
    :func:`prefilter_points` at its texel centres."""
    dirs = cube_directions(size)[0].reshape(-1, 3)
    return prefilter_points(pyramid, dirs, alpha, samples, fis, hot).reshape(6, size, size, 3)


def prefilter_points(
    pyramid: list[np.ndarray],
    dirs: np.ndarray,
    alpha: float,
    samples: int = DEFAULT_SAMPLES,
    fis: bool = True,
    hot: HotTexels | None = None,
) -> np.ndarray:
    """Prefiltered radiance ``(m, 3)`` at GGX ``alpha`` along unit ``dirs (m, 3)`` (the
    cube's frame) from a source pyramid.

    ``fis=False`` point-samples level 0 of the source (plain importance
    sampling: the estimator that shows fireflies). ``hot``: excess texels
    (:func:`split_hot_texels`) the pyramid lacks, summed exactly.
    """
    if not 0.0 < alpha <= 1.0:
        raise ParameterError(f"alpha must be in (0, 1], got {alpha}")
    dirs = np.ascontiguousarray(dirs, dtype=np.float64)
    n0 = pyramid[0].shape[1]
    omega_p = 4.0 * math.pi / (6.0 * n0 * n0)
    out = np.empty((dirs.shape[0], 3))
    table = np.empty((int(samples), 6))
    rows = _sample_table(float(alpha), int(samples), omega_p, len(pyramid), bool(fis), table)
    table = table[:rows]
    run_blocks(
        _prefilter_fis,
        out.shape[0],
        out.shape[0] * table.shape[0] * 60.0,
        *_packed_pyramid(pyramid),
        world_face_frames(),
        dirs,
        table,
        out,
    )
    if hot is not None and len(hot.dirs):
        run_blocks(_add_hot_texels, out.shape[0], out.shape[0] * len(hot.solid_angles) * 20.0,
                   *hot, dirs, float(alpha), 1.0 / lobe_normalization(alpha), out)  # fmt: skip
    return out


FIT_DENSITY = 2
"""Points per side of a level texel its least-squares fit is made to (:func:`fit_bilinear`)."""
FIT_ITERATIONS = 24
"""Conjugate-gradient steps of :func:`fit_bilinear`."""


@jit
def _count_taps(axes, dirs, size, counts):
    index = np.empty(MAX_TAPS, np.int64)
    weight = np.empty(MAX_TAPS)
    for k in range(dirs.shape[0]):
        counts[k] = cube_bilinear_taps(size, axes, dirs[k, 0], dirs[k, 1], dirs[k, 2], index,
                                       weight)  # fmt: skip


@jit
def _fill_taps(axes, dirs, size, offsets, index, weight):
    for k in range(dirs.shape[0]):
        o = offsets[k]
        cube_bilinear_taps(size, axes, dirs[k, 0], dirs[k, 1], dirs[k, 2], index[o:], weight[o:])


@jit
def _read_taps(offsets, index, weight, x, out):
    # out[k] = Σ_t weight · x[index] over the taps of row k (the bilinear read, A x)
    for k in range(out.shape[0]):
        for c in range(3):
            out[k, c] = 0.0
        for t in range(offsets[k], offsets[k + 1]):
            for c in range(3):
                out[k, c] += weight[t] * x[index[t], c]


@jit
def _spread_taps(offsets, index, weight, r, out):
    # out = Aᵀ r, rows in order (the same sums on every run)
    out[:] = 0.0
    for k in range(r.shape[0]):
        for t in range(offsets[k], offsets[k + 1]):
            for c in range(3):
                out[index[t], c] += weight[t] * r[k, c]


def bilinear_taps(dirs: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The texels and weights of the GPU's seam-correct bilinear read of a ``size``² cube at
    unit ``dirs (m, 3)`` (:func:`~shbake.texture.cube.cube_bilinear_taps`): direction ``k``
    blends texels ``index[offsets[k]:offsets[k+1]]`` (flat: ``(face · size + row) · size +
    column``) with ``weight`` over the same range."""
    dirs = np.ascontiguousarray(dirs, dtype=np.float64)
    axes = world_face_frames()
    counts = np.empty(dirs.shape[0], np.int64)
    _count_taps(axes, dirs, size, counts)
    offsets = np.zeros(dirs.shape[0] + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    index = np.empty(offsets[-1], np.int64)
    weight = np.empty(offsets[-1])
    _fill_taps(axes, dirs, size, offsets, index, weight)
    return offsets, index, weight


def fit_bilinear(dense: np.ndarray, size: int, iterations: int = FIT_ITERATIONS) -> np.ndarray:
    """Texel values of a ``size``² chain level whose seam-correct bilinear read (the GPU's,
    :func:`shbake.texture.cube.cube_bilinear`) best fits ``dense`` — the level's radiance at
    the texel centres of a finer cube ``(6, m·size, m·size, 3)`` — in least squares: ``A x ≈
    b``, ``A`` the bilinear weights of :func:`~shbake.texture.cube.cube_bilinear_taps`,
    solved by conjugate gradients on the normal equations (CGLS, Hestenes & Stiefel 1952)
    from the solid-angle box average, ``iterations`` steps, then clamped at 0.

    A level's value at its own texel centres is not what a GPU's bilinear read of it should
    hold where the lobe is not wide against the texel: the read between centres then misses
    what lies between them (a rough level of studio read at r 0.6 on Babylon.js's 8² and 4²
    faces: 62.6 % p95 from brute force at 4096 directions with centre values, 22.9 % with
    least-squares values).
    """
    offsets, index, weight = bilinear_taps(cube_directions(dense.shape[1])[0].reshape(-1, 3), size)
    x = dense
    while x.shape[1] > size:
        x = downsample_cube(x)
    x = x.reshape(-1, 3).copy()
    b = dense.reshape(-1, 3)
    ax = np.empty_like(b)
    _read_taps(offsets, index, weight, x, ax)
    r = b - ax
    s = np.empty_like(x)
    _spread_taps(offsets, index, weight, r, s)
    p = s.copy()
    gamma = (s * s).sum(axis=0)
    q = np.empty_like(b)
    for _ in range(int(iterations)):
        _read_taps(offsets, index, weight, p, q)
        qq = (q * q).sum(axis=0)
        step = np.divide(gamma, qq, out=np.zeros(3), where=qq > 0)
        x += step * p
        r -= step * q
        _spread_taps(offsets, index, weight, r, s)
        new = (s * s).sum(axis=0)
        p = s + np.divide(new, gamma, out=np.zeros(3), where=gamma > 0) * p
        gamma = new
    return np.maximum(x, 0.0).reshape(6, size, size, 3)


def reference_level(env: Environment, size: int, alpha: float) -> np.ndarray:
    """:func:`reference_radiance` at every texel of a ``size`` cube."""
    return reference_radiance(env, cube_directions(size)[0], alpha)


__all__ = [
    "HOT_CONTRAST",
    "HOT_TEXELS_MAX",
    "HotTexels",
    "bilinear_taps",
    "cube_directions",
    "cube_pyramid",
    "downsample_cube",
    "fit_bilinear",
    "lobe_normalization",
    "mirror_cube",
    "mirror_supersample",
    "prefilter_level",
    "prefilter_points",
    "reference_level",
    "split_hot_texels",
]
