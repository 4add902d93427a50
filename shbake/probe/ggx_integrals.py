"""The GGX reflection integrals ``E0`` and ``E1`` by visible-normal quadrature.

Silvennoinen et al. (2025), eq. 6–8, with ``f_DV = D V`` (no Fresnel)::

    E0(v, n, r) = ∫ L(l) f_DV(v, n, l) (n·l) dl
    E1(v, n, r) = ∫ L(l) f_DV(v, n, l) (1 − v·h)^5 (n·l) dl

GGX width ``α = r²`` for perceptual roughness ``r`` (``docs/CONVENTIONS.md``),
separable Smith ``G = G1(v) G1(l)`` (SPEC §4, as Mitsuba 3). Sampling
half vectors from the distribution of visible normals (Heitz 2018) leaves the
estimator weight ``f_DV (n·l) / p(l) = G1(l)``, so with ``N`` points ``u_k``
of a deterministic 2D Fibonacci lattice::

    E0 ≈ (1/N) Σ_k L(l_k) G1(l_k) [l_k·n > 0],   E1 adds (1 − v·h_k)^5.

``L`` is read from the lat-long map's nearest texel, so as ``N → ∞`` the
estimate converges to the exact integral of the piecewise-constant map — the
brute-force texel sum of :mod:`shbake.reference.brdf_shading`.

Everything that does not depend on the map (the directions, their texels and
weights at a fixed set of ``(v, n, r)``) is built once as a
:class:`QuadraturePlan`; a probe is then one gather.
"""

from dataclasses import dataclass

import numba
import numpy as np

from shbake.brdf.ggx import sample as vndf_sample
from shbake.brdf.ggx import smith_lambda
from shbake.brdf.sampling import tangent_frame
from shbake.errors import ParameterError
from shbake.jit import jit, pjit

ROUGHNESS_MIN = 0.02
"""Smallest perceptual roughness the integrals accept (GGX width 4e-4)."""
SAMPLES_LIMIT = 1 << 20
INV_GOLDEN = 0.6180339887498949


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
def sample_light(vx, vy, vz, nx, ny, nz, alpha, prm, ur, ua):
    """One visible-normal sample: world ``l``, weight ``G1(l)`` and ``(1 − v·h)^5``.

    ``prm`` is a scratch GGX parameter vector with ``prm[3] = prm[4] = α``.
    The weight is 0 when ``l`` falls below the surface.
    """
    (tx, ty, tz), (bx, by, bz) = tangent_frame(nx, ny, nz)
    lx_, ly_, lz_ = (
        tx * vx + ty * vy + tz * vz,
        bx * vx + by * vy + bz * vz,
        nx * vx + ny * vy + nz * vz,
    )
    sx, sy, sz = vndf_sample(prm, lx_, ly_, lz_, ur, ua)
    if sz <= 0.0:
        return 0.0, 0.0, 1.0, 0.0, 0.0
    g1 = 1.0 / (1.0 + smith_lambda(alpha, alpha, sx, sy, sz))
    hx, hy, hz = sx + lx_, sy + ly_, sz + lz_
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    vh = (hx * lx_ + hy * ly_ + hz * lz_) / hn
    tail = (1.0 - min(1.0, max(0.0, vh))) ** 5
    wx = sx * tx + sy * bx + sz * nx
    wy = sx * ty + sy * by + sz * ny
    wz = sx * tz + sy * bz + sz * nz
    return wx, wy, wz, g1, g1 * tail


@pjit
def _integrate_direct(views, normals, alphas, square, pixels, height, width, out0, out1):
    n = square.shape[0]
    for t in numba.prange(views.shape[0]):
        prm = np.zeros(6)
        prm[3] = prm[4] = alphas[t]
        a0 = np.zeros(3)
        a1 = np.zeros(3)
        for k in range(n):
            lx, ly, lz, w0, w1 = sample_light(
                views[t, 0], views[t, 1], views[t, 2],
                normals[t, 0], normals[t, 1], normals[t, 2],
                alphas[t], prm, square[k, 0], square[k, 1],
            )  # fmt: skip
            if w0 == 0.0:
                continue
            j = latlong_texel(lx, ly, lz, height, width)
            for c in range(3):
                a0[c] += w0 * pixels[j, c]
                a1[c] += w1 * pixels[j, c]
        for c in range(3):
            out0[t, c] = a0[c] / n
            out1[t, c] = a1[c] / n


@pjit
def _build_plan(views, normals, alphas, square, height, width, index, weight):
    n = square.shape[0]
    for t in numba.prange(views.shape[0]):
        prm = np.zeros(6)
        prm[3] = prm[4] = alphas[t]
        for k in range(n):
            lx, ly, lz, w0, _ = sample_light(
                views[t, 0], views[t, 1], views[t, 2],
                normals[t, 0], normals[t, 1], normals[t, 2],
                alphas[t], prm, square[k, 0], square[k, 1],
            )  # fmt: skip
            index[t, k] = latlong_texel(lx, ly, lz, height, width) if w0 > 0.0 else 0
            weight[t, k] = w0 / n
        order = np.argsort(index[t])  # memory order: neighbouring texels together
        index[t] = index[t][order]
        weight[t] = weight[t][order]


@pjit
def _gather(index, weight, pixels, out):
    for t in numba.prange(index.shape[0]):
        a0 = a1 = a2 = 0.0
        for k in range(index.shape[1]):
            j = index[t, k]
            w = weight[t, k]
            a0 += w * pixels[j, 0]
            a1 += w * pixels[j, 1]
            a2 += w * pixels[j, 2]
        out[t, 0], out[t, 1], out[t, 2] = a0, a1, a2


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
    samples : visible-normal samples per integral.
    """
    v, n, r = _check_geometry(views, normals, roughness)
    flat, h, w = _latlong_pixels(pixels)
    samples = check_samples(samples)
    e0 = np.empty((v.shape[0], 3))
    e1 = np.empty((v.shape[0], 3))
    _integrate_direct(v, n, ggx_alpha(r), fibonacci_square(samples), flat, h, w, e0, e1)
    return e0, e1


@dataclass
class QuadraturePlan:
    """Texels and weights of ``E0`` at fixed ``(v, n, r)`` targets for one map shape.

    ``index``/``weight``: ``(T, N)`` int32/float32, each row sorted by texel.
    Built once per (targets, samples, map shape); :meth:`e0` is one gather.
    """

    shape: tuple[int, int]
    index: np.ndarray
    weight: np.ndarray

    @classmethod
    def build(cls, views, normals, roughness, samples: int, shape: tuple[int, int]):
        v, n, r = _check_geometry(views, normals, roughness)
        samples = check_samples(samples)
        h, w = shape
        index = np.empty((v.shape[0], samples), dtype=np.int32)
        weight = np.empty((v.shape[0], samples), dtype=np.float32)
        _build_plan(v, n, ggx_alpha(r), fibonacci_square(samples), h, w, index, weight)
        return cls((h, w), index, weight)

    def e0(self, pixels) -> np.ndarray:
        """``E0`` at the plan's targets, ``(T, 3)`` float64."""
        flat, h, w = _latlong_pixels(pixels)
        if (h, w) != self.shape:
            raise ParameterError(f"plan is for {self.shape[1]}x{self.shape[0]} maps, got {w}x{h}")
        out = np.empty((self.index.shape[0], 3))
        _gather(self.index, self.weight, flat, out)
        return out
