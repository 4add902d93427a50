"""Projection of radiance on the sphere onto real SH: ``L_lm = ∫ L(ω) y_lm(ω) dω``.

Two quadratures:

* :func:`project_latlong` — the separable path of Ramamoorthi & Hanrahan 2002
  §6.1 for lat-long images. In the *image frame* (pole = the image's +Y,
  azimuth ``φ' = -2πu``, proper rotation of the world frame) every SH is
  ``P̄_l^m(cos θ') × cos/sin(mφ')`` and the pixel grid is a product grid, so
  (1) each row is summed against ``cos/sin(mφ'_j)`` — a small matrix product
  against one table shared by every row (or a real FFT when ``lmax`` is
  large) — and (2) the row sums are combined with ``P̄_l^m(cos θ'_i)`` times
  the row's quadrature weight. Cost ``O(lmax × pixels)``. The image-frame
  coefficients are rotated into the world frame at the end.

  Row centres ``θ_i = π(i+½)/H`` are the nodes of Fejér's first rule, so the
  weights are Fejér's (Waldvogel 2006): the projection is *exact* for any
  map whose content is band-limited below ``l = H`` (a constant map gives
  ``L_00 = sqrt(4π)`` and zeros, to rounding). The weights differ from the
  exact cell solid angles of SPEC §3 by O(pixel²) and sum to the same 4π;
  the midpoint rule with cell areas would leave e.g. −2.5e-5 in ``L_20`` of a
  constant 512×256 map.
* :func:`project_samples` — any set of directions with weights (cube maps:
  exact texel solid angles).
"""

from functools import lru_cache

import numba
import numpy as np
import scipy.fft

from shbake.conventions import check_lmax, n_coeffs
from shbake.errors import ParameterError
from shbake.jit import pjit
from shbake.sh.basis import real_sh_numba, recurrence_tables
from shbake.sh.rotation import SHRotation

IMAGE_FRAME = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""Rotation taking world directions to the lat-long image frame: ``d' = IMAGE_FRAME @ d``,
``x' = -d_z, y' = -d_x, z' = d_y`` (det +1)."""

FFT_MIN_LMAX = 64
"""From this ``lmax`` on, row sums use a real FFT instead of the cos/sin table."""


@lru_cache(maxsize=16)
def fejer_row_weights(height: int, width: int) -> np.ndarray:
    """Fejér first-rule weight of one pixel of each row, ``(2π/W) w_i``, shape ``(height,)``.

    ``w_i = (2/H) (1 - 2 Σ_{k=1}^{⌊H/2⌋} cos(2kθ_i)/(4k²-1))``, ``θ_i = π(i+½)/H``;
    ``Σ_i w_i = 2``. Read-only.
    """
    theta = np.pi * (np.arange(height) + 0.5) / height
    acc = np.zeros(height)
    for k in range(1, height // 2 + 1):
        acc += np.cos(2.0 * k * theta) / (4.0 * k * k - 1.0)
    w = (2.0 / height) * (1.0 - 2.0 * acc) * (2.0 * np.pi / width)
    w.flags.writeable = False
    return w


def _azimuth_tables(width: int, lmax: int) -> tuple[np.ndarray, np.ndarray]:
    # cos(mφ'_j), m = 0..lmax, and sin(mφ'_j), m = 1..lmax, over the first half of a
    # row (j < ⌈W/2⌉), as (m, j) rows; φ'_j = -2π(j+½)/W. Column W-1-j has
    # φ' = -φ'_j: the same cos, the opposite sin.
    half = (width + 1) // 2
    phi = -2.0 * np.pi * (np.arange(half) + 0.5) / width
    m = np.arange(lmax + 1)
    return (
        np.ascontiguousarray(np.cos(np.outer(m, phi))),
        np.ascontiguousarray(np.sin(np.outer(m[1:], phi))),
    )


@pjit(fastmath={"reassoc", "contract"})
def _row_sums_table(img, cos_t, sin_t, out):
    """Row sums against cos/sin(mφ') using the mirror symmetry of each row.

    ``out[i, c, 0] = Σ_j img[i, j, c]``, ``out[i, c, 2m-1] = Σ_j img cos(mφ'_j)``,
    ``out[i, c, 2m] = Σ_j img sin(mφ'_j)``. Pixels ``j`` and ``W-1-j`` are
    summed and differenced into a row buffer first (halving the work), then
    each output is a dot product over that buffer, vectorised (reassociation
    allowed here only; the result is still deterministic). Check-free kernel.
    """
    h, w, nc = img.shape
    nm = cos_t.shape[0]
    half = cos_t.shape[1]
    pairs = w // 2
    for i in numba.prange(h):
        sp = np.zeros((nc, half))
        dm = np.zeros((nc, half))
        for j in range(pairs):
            jj = w - 1 - j
            for c in range(nc):
                a = np.float64(img[i, j, c])
                b = np.float64(img[i, jj, c])
                sp[c, j] = a + b
                dm[c, j] = a - b
        if half > pairs:  # odd width: the middle column, φ' = -π
            for c in range(nc):
                sp[c, pairs] = np.float64(img[i, pairs, c])
        for c in range(nc):
            for m in range(nm):
                acc = 0.0
                for j in range(half):
                    acc += sp[c, j] * cos_t[m, j]
                out[i, c, 0 if m == 0 else 2 * m - 1] = acc
            for m in range(1, nm):
                acc = 0.0
                for j in range(half):
                    acc += dm[c, j] * sin_t[m - 1, j]
                out[i, c, 2 * m] = acc


def _row_sums_fft(img, lmax):
    h, w, nc = img.shape
    f = scipy.fft.rfft(np.asarray(img, dtype=np.float64), axis=1, workers=-1)[:, : lmax + 1, :]
    shift = np.exp(-1j * np.pi * np.arange(lmax + 1) / w)
    f = f * shift[None, :, None]
    out = np.empty((h, nc, 2 * lmax + 1))
    out[:, :, 0] = f[:, 0, :].real
    out[:, :, 1::2] = f[:, 1:, :].real.transpose(0, 2, 1)
    out[:, :, 2::2] = f[:, 1:, :].imag.transpose(0, 2, 1)
    return out


@pjit
def _legendre_sums(sums, cos_t, sin_t, weight, lmax, qmm, a, b, out):
    """Combine row sums with P̄_l^m(cos θ_i) w_i (check-free, parallel over m)."""
    h = sums.shape[0]
    nc = sums.shape[1]
    for m in numba.prange(lmax + 1):
        kc = 0 if m == 0 else 2 * m - 1
        ks = 2 * m
        for i in range(h):
            z = cos_t[i]
            scale = weight[i] * sin_t[i] ** m
            if m > 0:
                scale *= 1.4142135623730951
            q2 = qmm[m]
            q1 = 0.0
            for l in range(m, lmax + 1):
                if l == m:
                    q = q2
                elif l == m + 1:
                    q1 = np.sqrt(2.0 * m + 3.0) * z * q2
                    q = q1
                else:
                    q = a[l, m] * (z * q1 - b[l, m] * q2)
                    q2 = q1
                    q1 = q
                p = q * scale
                base = l * (l + 1)
                for c in range(nc):
                    out[base + m, c] += p * sums[i, c, kc]
                    if m > 0:
                        out[base - m, c] += p * sums[i, c, ks]


def project_latlong_image_frame(img, lmax: int) -> np.ndarray:
    """Coefficients in the image frame (see module doc); ``img`` is ``(H, W, C)``."""
    h, w, nc = img.shape
    if lmax >= FFT_MIN_LMAX and 2 * lmax < w:
        sums = _row_sums_fft(img, lmax)
    else:
        sums = np.empty((h, nc, 2 * lmax + 1))
        _row_sums_table(np.ascontiguousarray(img), *_azimuth_tables(w, lmax), sums)
    theta = np.pi * (np.arange(h) + 0.5) / h
    qmm, a, b = recurrence_tables(lmax)
    out = np.zeros((n_coeffs(lmax), nc))
    _legendre_sums(
        sums, np.cos(theta), np.sin(theta), fejer_row_weights(h, w), lmax, qmm, a, b, out
    )
    return out


def project_latlong(img, lmax: int) -> np.ndarray:
    """Project a lat-long radiance image onto real SH in the world frame.

    Parameters
    ----------
    img : ndarray, (H, W, C), float32 or float64
        Radiance, lat-long layout of SPEC §3 (row 0 = +Y, centre = +Z, pixels
        are cells with exact solid angles). Must be finite (validated upstream).
    lmax : int, 0 … 128

    Returns
    -------
    ndarray, ((lmax+1)^2, C), float64
        ``L_lm = Σ_pixels L(ω_p) y_lm(ω_p) w_p`` with Fejér weights ``w_p``
        (exact for content band-limited below ``l = H``).
    """
    lmax = check_lmax(lmax)
    img = np.asarray(img)
    if img.ndim != 3 or img.dtype not in (np.float32, np.float64):
        raise ParameterError(f"expected an (H, W, C) float image, got {img.shape} {img.dtype}")
    local = project_latlong_image_frame(img, lmax)
    return _to_world(lmax).apply(local)


@lru_cache(maxsize=8)
def _to_world(lmax: int) -> SHRotation:
    # c_world = M(IMAGE_FRAME)ᵀ c_image = M(IMAGE_FRAMEᵀ) c_image; a constant per lmax.
    return SHRotation(IMAGE_FRAME.T, lmax)


def project_samples(dirs, weights, values, lmax: int, chunk: int = 65536) -> np.ndarray:
    """``Σ_k values_k y(dirs_k) weights_k`` — projection of any weighted sample set.

    Parameters
    ----------
    dirs : (N, 3) unit vectors; weights : (N,) solid angles in sr;
    values : (N, C) radiance.
    """
    lmax = check_lmax(lmax)
    dirs = np.asarray(dirs, dtype=np.float64)
    wv = np.asarray(values, dtype=np.float64) * np.asarray(weights, dtype=np.float64)[:, None]
    out = np.zeros((n_coeffs(lmax), wv.shape[1]))
    for s in range(0, dirs.shape[0], chunk):
        out += real_sh_numba(dirs[s : s + chunk], lmax).T @ wv[s : s + chunk]
    return out
