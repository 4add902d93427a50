"""Real spherical harmonics (SPEC §2).

Real, orthonormal over the sphere, no Condon–Shortley phase, flat index
``i = l*(l+1) + m``. For a unit vector ``d = (x, y, z)`` with ``θ`` from +Z and
``φ`` from +X toward +Y::

    y_l0  = P̄_l^0(z)
    y_lm  = √2 P̄_l^m(z) cos(mφ),   m > 0
    y_l-m = √2 P̄_l^m(z) sin(mφ),   m > 0

where ``P̄_l^m = sqrt((2l+1)/(4π) (l-m)!/(l+m)!) P_l^m`` (no ``(-1)^m``).

The evaluation never forms ``P_l^m`` nor ``sin^m θ`` separately: it runs the
normalised recurrence on ``Q_l^m = P̄_l^m / sin^m θ`` (bounded growth, no
overflow to ``lmax`` ≫ 128) and multiplies by ``Re/Im (x + i y)^m =
sin^m θ cos/sin(mφ)``, which is exact at the poles and needs no ``atan2``
(the approach of sphericart, Bigi et al. 2023).

Recurrences (``Q_0^0 = 1/sqrt(4π)``)::

    Q_m^m     = sqrt((2m+1)/(2m)) Q_{m-1}^{m-1}
    Q_{m+1}^m = sqrt(2m+3) z Q_m^m
    Q_l^m     = a_lm (z Q_{l-1}^m - b_lm Q_{l-2}^m)
    a_lm = sqrt((4l²-1)/(l²-m²)),  b_lm = sqrt(((l-1)²-m²)/(4(l-1)²-1))
"""

from functools import cache

import numba
import numpy as np

from shbake.conventions import check_lmax, lmax_of, n_coeffs
from shbake.errors import ParameterError
from shbake.jit import jit, pjit

SQRT2 = np.sqrt(2.0)


@cache
def recurrence_tables(lmax: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients of the normalised recurrence, shape ``(lmax+1, lmax+1)`` each.

    Returns ``(qmm, a, b)``: ``qmm[m] = Q_m^m`` (a constant), ``a[l, m]`` and
    ``b[l, m]`` for ``l >= m + 2`` (zero elsewhere). Read-only arrays.
    """
    qmm = np.empty(lmax + 1)
    qmm[0] = 1.0 / np.sqrt(4.0 * np.pi)
    for m in range(1, lmax + 1):
        qmm[m] = qmm[m - 1] * np.sqrt((2.0 * m + 1.0) / (2.0 * m))
    a = np.zeros((lmax + 1, lmax + 1))
    b = np.zeros((lmax + 1, lmax + 1))
    for m in range(lmax + 1):
        for l in range(m + 2, lmax + 1):
            a[l, m] = np.sqrt((4.0 * l * l - 1.0) / (l * l - m * m))
            b[l, m] = np.sqrt(((l - 1.0) ** 2 - m * m) / (4.0 * (l - 1.0) ** 2 - 1.0))
    for t in (qmm, a, b):
        t.flags.writeable = False
    return qmm, a, b


def _as_directions(dirs) -> np.ndarray:
    d = np.asarray(dirs, dtype=np.float64)
    if d.shape[-1:] != (3,):
        raise ParameterError(f"directions must have a last axis of 3, got shape {d.shape}")
    if not np.all(np.isfinite(d)):
        raise ParameterError("directions must be finite")
    norm = np.linalg.norm(d, axis=-1)
    if np.any(norm == 0.0):
        raise ParameterError("directions must be non-zero vectors")
    return d / norm[..., None]


def real_sh(dirs, lmax: int) -> np.ndarray:
    """Evaluate all real SH up to ``lmax`` at unit directions (vectorised numpy).

    Parameters
    ----------
    dirs : array_like, shape (..., 3)
        Directions; normalised here.
    lmax : int, 0 … 128
        Highest band.

    Returns
    -------
    ndarray, shape (..., (lmax+1)^2), float64
    """
    lmax = check_lmax(lmax)
    d = _as_directions(dirs)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    qmm, a, b = recurrence_tables(lmax)
    out = np.empty(d.shape[:-1] + (n_coeffs(lmax),))
    cm = np.ones_like(x)  # Re (x + iy)^m
    sm = np.zeros_like(x)  # Im (x + iy)^m
    for m in range(lmax + 1):
        if m > 0:
            cm, sm = cm * x - sm * y, cm * y + sm * x
        q_lm2 = np.full_like(z, qmm[m])
        q_lm1 = None
        for l in range(m, lmax + 1):
            if l == m:
                q = q_lm2
            elif l == m + 1:
                q_lm1 = np.sqrt(2.0 * m + 3.0) * z * q_lm2
                q = q_lm1
            else:
                q = a[l, m] * (z * q_lm1 - b[l, m] * q_lm2)
                q_lm2, q_lm1 = q_lm1, q
            base = l * (l + 1)
            if m == 0:
                out[..., base] = q
            else:
                out[..., base + m] = SQRT2 * q * cm
                out[..., base - m] = SQRT2 * q * sm
    return out


@jit
def sh_eval_into(x, y, z, lmax, qmm, a, b, out):
    """Write the ``(lmax+1)^2`` real SH of the unit vector ``(x, y, z)`` into ``out``.

    Check-free kernel: ``(x, y, z)`` must be unit length, ``out`` long enough,
    ``qmm, a, b`` from :func:`recurrence_tables` of at least ``lmax``.
    """
    cm = 1.0
    sm = 0.0
    for m in range(lmax + 1):
        if m > 0:
            cm, sm = cm * x - sm * y, cm * y + sm * x
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
            base = l * (l + 1)
            if m == 0:
                out[base] = q
            else:
                out[base + m] = 1.4142135623730951 * q * cm
                out[base - m] = 1.4142135623730951 * q * sm


@pjit
def _sh_eval_many(d, lmax, qmm, a, b, out):
    for i in numba.prange(d.shape[0]):
        sh_eval_into(d[i, 0], d[i, 1], d[i, 2], lmax, qmm, a, b, out[i])


def real_sh_numba(dirs, lmax: int) -> np.ndarray:
    """Same as :func:`real_sh`, evaluated by the parallel numba kernel."""
    lmax = check_lmax(lmax)
    d = _as_directions(dirs)
    flat = np.ascontiguousarray(d.reshape(-1, 3))
    out = np.empty((flat.shape[0], n_coeffs(lmax)))
    qmm, a, b = recurrence_tables(lmax)
    _sh_eval_many(flat, lmax, qmm, a, b, out)
    return out.reshape(d.shape[:-1] + (n_coeffs(lmax),))


def evaluate(coeffs, dirs) -> np.ndarray:
    """Reconstruct ``Σ_i c_i y_i(d)`` at directions ``dirs``.

    ``coeffs`` has shape ``(n,)`` or ``(n, C)``; the result has shape
    ``dirs.shape[:-1]`` or ``dirs.shape[:-1] + (C,)``.
    """
    c = np.asarray(coeffs, dtype=np.float64)
    lmax = lmax_of(c.shape[0])
    return real_sh_numba(dirs, lmax) @ c
