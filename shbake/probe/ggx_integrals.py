"""The GGX reflection integrals ``E0`` and ``E1`` by visible-normal quadrature.

Silvennoinen et al. (2025), eq. 6–8, with ``f_DV = D V`` (no Fresnel)::

    E0(v, n, r) = ∫ L(l) f_DV(v, n, l) (n·l) dl
    E1(v, n, r) = ∫ L(l) f_DV(v, n, l) (1 − v·h)^5 (n·l) dl

GGX width ``α = r²`` for perceptual roughness ``r`` (``docs/CONVENTIONS.md``),
separable Smith ``G = G1(v) G1(l)`` (SPEC §4, as Mitsuba 3). Sampling
half vectors from the distribution of visible normals (Heitz 2018) has density
``p_B(l) = G1(v) D(h) / (4 n·v)`` and leaves ``f_DV (n·l) = p_B(l) G1(l)``.
The map is sampled too: texel ``j`` with probability ∝ luminance × solid
angle, uniformly inside it (density ``p_L``). ``N`` samples of each,
combined by the balance heuristic (Veach 1997), on a deterministic 2D
Fibonacci lattice::

    E0 ≈ (1/N) Σ_{l ∈ B ∪ L} L(l) G1(l) p_B(l) / (p_B(l) + p_L(l)) [n·l > 0],
    E1 adds (1 − v·h)^5.

The map's samples converge fast where a small bright source (a sun, a lamp)
dominates; the BRDF's where the lobe is sharp. ``L`` is the lat-long texel
holding ``l``, so as ``N → ∞`` the estimate converges to the exact integral
of the piecewise-constant map — the brute-force texel sum of
:mod:`shbake.reference.brdf_shading`.

:func:`ggx_integrals` is this estimator (the ground truth). The fit's
targets use a :class:`QuadraturePlan` of the visible-normal samples alone:
everything that does not depend on the map (the directions, their texels
and weights at a fixed set of ``(v, n, r)``) is built once, with filtered
importance sampling on a solid-angle pyramid of the map, and a probe is
then one gather.
"""

from dataclasses import dataclass

import numba
import numpy as np

from shbake.brdf.ggx import ggx_d, smith_lambda
from shbake.brdf.ggx import sample as vndf_sample
from shbake.brdf.sampling import tangent_frame
from shbake.conventions import REC709_LUMINANCE
from shbake.envmap.layouts import latlong_solid_angles
from shbake.errors import ParameterError
from shbake.jit import jit, pjit

ROUGHNESS_MIN = 0.02
"""Smallest perceptual roughness the integrals accept (GGX width 4e-4)."""
SAMPLES_LIMIT = 1 << 20
PYRAMID_LEVELS = 6
LOD_BIAS = 1.0
"""Pyramid levels one coarser than the sample footprint (Křivánek & Colbert 2008)."""
INV_GOLDEN = 0.6180339887498949
BRIGHT_TEXELS = 64
"""Texels the fit targets take as point lights: at most this many, the brightest ..."""
BRIGHT_SHARE = 1e-4
"""... among those holding more than this share of the map's luminance × solid angle."""


def ggx_alpha(roughness):
    """GGX width ``α = r²`` of perceptual roughness ``r`` (Burley 2012; SPEC §1)."""
    return np.asarray(roughness, dtype=float) ** 2


def fibonacci_square(n: int) -> np.ndarray:
    """``n`` points of the 2D Fibonacci lattice in ``[0, 1)²``: ``((k+½)/n, frac(k/φ))``."""
    k = np.arange(n)
    return np.stack([(k + 0.5) / n, np.mod(k * INV_GOLDEN, 1.0)], axis=1)


def check_roughness(r, lo: float = ROUGHNESS_MIN, hi: float = 1.0, name: str = "roughness"):
    """Refuse perceptual roughness outside ``[lo, hi]`` (or non-finite)."""
    a = np.asarray(r, dtype=float)
    if not np.all(np.isfinite(a)) or np.any(a < lo - 1e-12) or np.any(a > hi + 1e-12):
        raise ParameterError(f"{name} must lie in [{lo:g}, {hi:g}], got {np.ravel(a)[:4]}")
    return a


def check_samples(n) -> int:
    if not isinstance(n, int | np.integer) or not 16 <= n <= SAMPLES_LIMIT:
        raise ParameterError(f"samples must be an integer in [16, {SAMPLES_LIMIT}], got {n}")
    return int(n)


@jit
def latlong_texel(dx, dy, dz, height, width):
    """Flat index of the lat-long texel holding world direction ``d`` (SPEC §3)."""
    u = np.arctan2(dx, -dz) / (2.0 * np.pi)
    if u < 0.0:
        u += 1.0
    v = np.arccos(min(1.0, max(-1.0, dy))) / np.pi
    col = min(int(u * width), width - 1)
    row = min(int(v * height), height - 1)
    return row * width + col


@jit
def _vndf_pdf(vx, vy, vz, lx, ly, lz, alpha):
    """Density ``p(l) = G1(v) D(h) / (4 n·v)`` (1/sr), ``G1(l)`` and ``(1 − v·h)^5``
    for local unit ``v``, ``l`` above the surface."""
    hx, hy, hz = vx + lx, vy + ly, vz + lz
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / hn, hy / hn, hz / hn
    g1v = 1.0 / (1.0 + smith_lambda(alpha, alpha, vx, vy, vz))
    g1l = 1.0 / (1.0 + smith_lambda(alpha, alpha, lx, ly, lz))
    tail = (1.0 - min(1.0, max(0.0, vx * hx + vy * hy + vz * hz))) ** 5
    return g1v * ggx_d(alpha, alpha, hx, hy, hz) / (4.0 * vz), g1l, tail


@jit
def surface_frame(vx, vy, vz, nx, ny, nz):
    """Tangent ``t``, bitangent ``b`` of ``n`` (Duff et al.) and ``v`` in that frame."""
    (tx, ty, tz), (bx, by, bz) = tangent_frame(nx, ny, nz)
    v_loc = (tx * vx + ty * vy + tz * vz, bx * vx + by * vy + bz * vz, nx * vx + ny * vy + nz * vz)
    return (tx, ty, tz), (bx, by, bz), v_loc


@jit
def sample_light(t, b, n, v_loc, alpha, prm, ur, ua):
    """One visible-normal sample in the frame ``(t, b, n)`` of :func:`surface_frame`: world
    ``l``, weights ``G1(l)`` and ``G1(l) (1 − v·h)^5``, and the density
    ``p(l) = G1(v) D(h) / (4 n·v)`` (1/sr).

    ``prm`` is a scratch GGX parameter vector with ``prm[3] = prm[4] = α``.
    The weights are 0 when ``l`` falls below the surface.
    """
    sx, sy, sz = vndf_sample(prm, v_loc[0], v_loc[1], v_loc[2], ur, ua)
    if sz <= 0.0:
        return 0.0, 0.0, 1.0, 0.0, 0.0, 1.0
    pdf, g1, tail = _vndf_pdf(v_loc[0], v_loc[1], v_loc[2], sx, sy, sz, alpha)
    wx = sx * t[0] + sy * b[0] + sz * n[0]
    wy = sx * t[1] + sy * b[1] + sz * n[1]
    wz = sx * t[2] + sy * b[2] + sz * n[2]
    return wx, wy, wz, g1, g1 * tail, pdf


@jit
def _texel_direction(j, f, u, height, width):
    """A point of lat-long texel ``j``: ``f`` uniform in ``cos θ``, ``u`` in ``φ`` (SPEC §3)."""
    row, col = j // width, j % width
    z0, z1 = np.cos(np.pi * row / height), np.cos(np.pi * (row + 1) / height)
    y = z0 - f * (z0 - z1)
    s = np.sqrt(max(0.0, 1.0 - y * y))
    phi = 2.0 * np.pi * (col + u) / width
    return s * np.sin(phi), y, -s * np.cos(phi)


@pjit
def _integrate_mis(views, normals, alphas, square, pixels, height, width, cdf, density,
                   out0, out1):  # fmt: skip
    """Balance-heuristic MIS of ``N`` visible-normal and ``N`` map samples (module docstring)."""
    n = square.shape[0]
    texels = cdf.shape[0]
    for t in numba.prange(views.shape[0]):
        prm = np.zeros(6)
        prm[3] = prm[4] = alphas[t]
        nx, ny, nz = normals[t, 0], normals[t, 1], normals[t, 2]
        (tx, ty, tz), (bx, by, bz), v_loc = surface_frame(
            views[t, 0], views[t, 1], views[t, 2], nx, ny, nz
        )
        a0 = np.zeros(3)
        a1 = np.zeros(3)
        for k in range(n):
            # the BRDF's sample
            lx, ly, lz, g1, g1_tail, p_brdf = sample_light(
                (tx, ty, tz), (bx, by, bz), (nx, ny, nz), v_loc, alphas[t], prm,
                square[k, 0], square[k, 1],
            )  # fmt: skip
            if g1 > 0.0:
                j = latlong_texel(lx, ly, lz, height, width)
                w = p_brdf / (p_brdf + density[j])
                for c in range(3):
                    a0[c] += w * g1 * pixels[j, c]
                    a1[c] += w * g1_tail * pixels[j, c]
            # the map's sample
            if texels == 0:
                continue
            u = square[k, 0]
            j = min(np.searchsorted(cdf, u, side="right"), texels - 1)
            lo = cdf[j - 1] if j > 0 else 0.0
            f = (u - lo) / (cdf[j] - lo) if cdf[j] > lo else 0.5
            lx, ly, lz = _texel_direction(j, min(max(f, 0.0), 1.0), square[k, 1], height, width)
            l_loc = (
                tx * lx + ty * ly + tz * lz,
                bx * lx + by * ly + bz * lz,
                nx * lx + ny * ly + nz * lz,
            )
            if l_loc[2] <= 0.0:
                continue
            p_brdf, g1, tail = _vndf_pdf(*v_loc, *l_loc, alphas[t])
            w = p_brdf / (p_brdf + density[j])
            for c in range(3):
                a0[c] += w * g1 * pixels[j, c]
                a1[c] += w * g1 * tail * pixels[j, c]
        for c in range(3):
            out0[t, c] = a0[c] / n
            out1[t, c] = a1[c] / n


def _luminous_weight(flat: np.ndarray, height: int, width: int):
    """Luminance × solid angle per texel (negative luminance counts as 0), and the
    solid angles (flat, float64)."""
    omega = latlong_solid_angles(height, width).reshape(-1)
    return np.maximum(flat.astype(np.float64) @ REC709_LUMINANCE, 0.0) * omega, omega


def light_distribution(flat: np.ndarray, height: int, width: int):
    """Texel CDF ∝ luminance × solid angle and the matching density per steradian.

    A black map has an empty CDF (then only the BRDF is sampled).
    """
    weight, omega = _luminous_weight(flat, height, width)
    total = weight.sum()
    if not total > 0.0:
        return np.zeros(0), np.zeros(flat.shape[0])
    cdf = np.cumsum(weight) / total
    cdf[-1] = 1.0
    return cdf, weight / total / omega


def bright_texels(flat: np.ndarray, height: int, width: int):
    """The map's brightest texels as point lights: flat indices, world directions (texel
    centres) and ``L Ω`` (:data:`BRIGHT_TEXELS`, :data:`BRIGHT_SHARE`)."""
    weight, omega = _luminous_weight(flat, height, width)
    total = weight.sum()
    if not total > 0.0:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    top = np.flatnonzero(weight > BRIGHT_SHARE * total)
    if top.size > BRIGHT_TEXELS:  # the brightest; ties broken by index, so deterministic
        order = np.lexsort((top, -weight[top]))[:BRIGHT_TEXELS]
        top = np.sort(top[order])
    dirs = np.array([_texel_direction(j, 0.5, 0.5, height, width) for j in top]).reshape(-1, 3)
    return top, dirs, flat[top].astype(np.float64) * omega[top, None]


@pjit
def _add_point_lights(views, normals, alphas, dirs, energy, out):
    """``out += Σ_k f_DV(v, n, l_k) (n·l_k) E_k``: ``G1(v) G1(l) D(h) / (4 n·v)`` per light
    (:func:`_vndf_pdf` with the per-target factors hoisted)."""
    for t in numba.prange(views.shape[0]):
        nx, ny, nz = normals[t, 0], normals[t, 1], normals[t, 2]
        (tx, ty, tz), (bx, by, bz), (v0, v1, v2) = surface_frame(
            views[t, 0], views[t, 1], views[t, 2], nx, ny, nz
        )
        a = alphas[t]
        a2 = a * a
        scale = 1.0 / ((1.0 + smith_lambda(a, a, v0, v1, v2)) * 4.0 * v2 * np.pi * a2)
        for k in range(dirs.shape[0]):
            lx, ly, lz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
            l2 = nx * lx + ny * ly + nz * lz
            if l2 <= 0.0:
                continue
            l0, l1 = tx * lx + ty * ly + tz * lz, bx * lx + by * ly + bz * lz
            h0, h1, h2 = v0 + l0, v1 + l1, v2 + l2
            hz2 = h2 * h2 / (h0 * h0 + h1 * h1 + h2 * h2)
            d = hz2 * (a2 - 1.0) + 1.0  # D(h) = a2 / (π d²) = 1 / (π a2 (d/a2)²)
            g1l = 2.0 / (1.0 + np.sqrt(1.0 + a2 * (l0 * l0 + l1 * l1) / (l2 * l2)))
            w = scale * g1l * a2 * a2 / (d * d)
            for c in range(3):
                out[t, c] += w * energy[k, c]


@jit
def _row_solid_angle(row, height, width):
    """Solid angle of one texel in lat-long row ``row`` (sr)."""
    return (np.cos(np.pi * row / height) - np.cos(np.pi * (row + 1) / height)) * 2.0 * np.pi / width


@jit
def _filtered_texel(lx, ly, lz, pdf, n, height, width, levels, level_offsets, log2_omega):
    """Pyramid texel (flat, across levels) for a sample of density ``pdf`` among ``n``.

    Level ``k = ⌊½ log2(Ω_s / Ω_texel) + 1⌋`` clamped to ``[0, levels − 1]``, where
    ``Ω_s = 1/(n p)`` is the sample's share of the sphere and ``Ω_texel`` the
    level-0 texel it lands in (Křivánek & Colbert 2008); ``log2_omega[row]``
    is ``log2 Ω_texel`` per row.
    """
    j = latlong_texel(lx, ly, lz, height, width)
    row, col = j // width, j % width
    lod = -0.5 * (np.log2(n * pdf) + log2_omega[row])
    k = min(max(int(np.floor(lod + LOD_BIAS)), 0), levels - 1)
    return level_offsets[k] + (row >> k) * (width >> k) + (col >> k)


@pjit
def _plan_rows(views, normals, alphas, square, height, width, level_offsets, index, weight, count):
    n = square.shape[0]
    levels = level_offsets.shape[0] - 1
    log2_omega = np.empty(height)
    for row in range(height):
        log2_omega[row] = np.log2(_row_solid_angle(row, height, width))
    for t in numba.prange(views.shape[0]):
        prm = np.zeros(6)
        prm[3] = prm[4] = alphas[t]
        nrm = (normals[t, 0], normals[t, 1], normals[t, 2])
        tan, bit, v_loc = surface_frame(views[t, 0], views[t, 1], views[t, 2], *nrm)
        for k in range(n):
            lx, ly, lz, w0, _, pdf = sample_light(
                tan, bit, nrm, v_loc, alphas[t], prm, square[k, 0], square[k, 1]
            )
            if w0 > 0.0:
                index[t, k] = _filtered_texel(
                    lx, ly, lz, pdf, n, height, width, levels, level_offsets, log2_omega
                )
            else:
                index[t, k] = 0
            weight[t, k] = w0 / n
        # memory order, then one entry per texel
        order = np.argsort(index[t])
        idx = index[t][order]
        wgt = weight[t][order]
        m = 0
        for k in range(n):
            if wgt[k] == 0.0:
                continue
            if m > 0 and idx[k] == index[t, m - 1]:
                weight[t, m - 1] += wgt[k]
            else:
                index[t, m] = idx[k]
                weight[t, m] = wgt[k]
                m += 1
        count[t] = m


@pjit
def _compact(index, weight, offsets, flat_index, flat_weight):
    for t in numba.prange(index.shape[0]):
        a = offsets[t]
        for k in range(offsets[t + 1] - a):
            flat_index[a + k] = index[t, k]
            flat_weight[a + k] = weight[t, k]


@jit
def _downsample(src, height, width, dst):
    """One pyramid step: 2×2 texels averaged with their solid angles."""
    for i in range(height // 2):
        w0 = _row_solid_angle(2 * i, height, width)
        w1 = _row_solid_angle(2 * i + 1, height, width)
        s = 0.5 / (w0 + w1)
        for j in range(width // 2):
            a, b = (2 * i) * width + 2 * j, (2 * i + 1) * width + 2 * j
            for c in range(3):
                dst[i * (width // 2) + j, c] = s * (
                    w0 * (src[a, c] + src[a + 1, c]) + w1 * (src[b, c] + src[b + 1, c])
                )


@pjit
def _gather(offsets, index, weight, pixels, out):
    for t in numba.prange(offsets.shape[0] - 1):
        a0 = a1 = a2 = 0.0
        for k in range(offsets[t], offsets[t + 1]):
            j = index[k]
            w = weight[k]
            a0 += w * pixels[j, 0]
            a1 += w * pixels[j, 1]
            a2 += w * pixels[j, 2]
        out[t, 0], out[t, 1], out[t, 2] = a0, a1, a2


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


def _check_geometry(views, normals, roughness):
    v = np.ascontiguousarray(np.asarray(views, dtype=float).reshape(-1, 3))
    n = np.ascontiguousarray(np.asarray(normals, dtype=float).reshape(-1, 3))
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(roughness, float), (v.shape[0],)))
    if v.shape != n.shape:
        raise ParameterError("views and normals must have the same number of directions")
    for name, d in (("views", v), ("normals", n)):
        if np.any(np.abs(np.linalg.norm(d, axis=1) - 1.0) > 1e-6):
            raise ParameterError(f"{name} must be unit vectors")
    if np.any(np.einsum("ij,ij->i", v, n) <= 0.0):
        raise ParameterError("every view must lie above its surface (n·v > 0)")
    check_roughness(r)
    return v, n, r


def _latlong_pixels(pixels: np.ndarray) -> tuple[np.ndarray, int, int]:
    if pixels.ndim != 3 or pixels.shape[2] != 3 or pixels.shape[1] != 2 * pixels.shape[0]:
        raise ParameterError("GGX integrals take a lat-long (2:1) RGB map")
    h, w = pixels.shape[:2]
    return np.ascontiguousarray(pixels.reshape(-1, 3), dtype=np.float32), h, w


def ggx_integrals(pixels, views, normals, roughness, samples: int = 4096):
    """``E0`` and ``E1``, each ``(T, 3)``, at ``T`` world-space ``(v, n, r)``.

    Parameters
    ----------
    pixels : (H, 2H, 3) lat-long radiance (finite, ≥ 0).
    views, normals : (T, 3) unit world directions with ``n·v > 0``; ``v`` points
        from the surface toward the viewer.
    roughness : scalar or (T,) perceptual roughness ``r`` in ``[0.02, 1]``.
    samples : visible-normal samples, and as many map samples, per integral.
    """
    v, n, r = _check_geometry(views, normals, roughness)
    flat, h, w = _latlong_pixels(pixels)
    samples = check_samples(samples)
    e0 = np.empty((v.shape[0], 3))
    e1 = np.empty((v.shape[0], 3))
    cdf, density = light_distribution(flat, h, w)
    _integrate_mis(v, n, ggx_alpha(r), fibonacci_square(samples), flat, h, w, cdf, density, e0, e1)
    return e0, e1


@dataclass
class QuadraturePlan:
    """Texels and weights of ``E0`` at fixed ``(v, n, r)`` targets for one map shape.

    Filtered importance sampling (Křivánek & Colbert 2008): each of the
    ``samples`` visible-normal samples reads the level of the map's
    solid-angle pyramid whose texels match its share of the sphere, so a
    broad lobe reads a coarse level. Samples that land in one texel are
    merged; rows are stored back to back (``offsets``, ``index`` into the
    stacked pyramid, ``weight``), each sorted by texel. Built once per
    (targets, samples, map shape); :meth:`e0` is one pyramid build and one
    gather. A map's brightest texels (:func:`bright_texels`: a sun, lamps),
    whose few samples would make every target noisy, are taken out of the
    pyramid and added exactly as point lights at their centres.
    """

    shape: tuple[int, int]
    levels: int
    offsets: np.ndarray
    index: np.ndarray
    weight: np.ndarray
    views: np.ndarray
    normals: np.ndarray
    alphas: np.ndarray

    @classmethod
    def build(cls, views, normals, roughness, samples: int, shape: tuple[int, int]):
        v, n, r = _check_geometry(views, normals, roughness)
        samples = check_samples(samples)
        levels = pyramid_levels(shape)
        index = np.empty((v.shape[0], samples), dtype=np.int32)
        weight = np.empty((v.shape[0], samples), dtype=np.float32)
        count = np.empty(v.shape[0], dtype=np.int64)
        square = fibonacci_square(samples)
        starts = level_offsets(shape, levels)
        _plan_rows(v, n, ggx_alpha(r), square, shape[0], shape[1], starts, index, weight, count)
        offsets = np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
        flat_index = np.empty(offsets[-1], dtype=np.int32)
        flat_weight = np.empty(offsets[-1], dtype=np.float32)
        _compact(index, weight, offsets, flat_index, flat_weight)
        return cls(tuple(shape), levels, offsets, flat_index, flat_weight, v, n, ggx_alpha(r))

    def e0(self, pixels) -> np.ndarray:
        """``E0`` at the plan's targets, ``(T, 3)`` float64."""
        flat, h, w = _latlong_pixels(pixels)
        if (h, w) != self.shape:
            raise ParameterError(f"plan is for {self.shape[1]}x{self.shape[0]} maps, got {w}x{h}")
        lights, dirs, energy = bright_texels(flat, h, w)
        if lights.size:
            flat = flat.copy()
            flat[lights] = 0.0
        pyramid = latlong_pyramid(flat, self.shape, self.levels)
        out = np.empty((self.offsets.shape[0] - 1, 3))
        _gather(self.offsets, self.index, self.weight, pyramid, out)
        if lights.size:
            _add_point_lights(self.views, self.normals, self.alphas, dirs, energy, out)
        return out
