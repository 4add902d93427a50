"""Zonal (radially symmetric) convolution kernels (SPEC §4).

A kernel ``k(ω·n)`` convolved with lighting ``L`` gives, by the Funk–Hecke
theorem, ``E_lm = K_l L_lm`` with ``K_l = 2π ∫_{-1}^{1} k(t) P_l(t) dt``; every
function here returns ``K_l`` for ``l = 0 … lmax`` so that
``E(n) = Σ K_l L_lm y_lm(n)``.
"""

from math import lgamma

import numpy as np

from shbake.conventions import band_of_index, check_lmax, lmax_of
from shbake.errors import ParameterError


def _central_binomial_ratio(n: int) -> float:
    """``(2n)! / (2^n n!)^2`` computed in log space (finite for any n)."""
    return float(np.exp(lgamma(2 * n + 1) - 2 * (n * np.log(2.0) + lgamma(n + 1))))


def lambert_kernel(lmax: int) -> np.ndarray:
    """Clamped-cosine kernel ``Â_l`` of Lambert irradiance, ``l = 0 … lmax``.

    ``E(n) = ∫ L(ω) max(0, n·ω) dω = Σ Â_l L_lm y_lm(n)`` (Ramamoorthi &
    Hanrahan 2001, eq. 8–9): ``Â_0 = π``, ``Â_1 = 2π/3``, odd ``l > 1`` vanish,
    even ``l``: ``Â_l = 2π (-1)^(l/2-1) / ((l+2)(l-1)) · l! / (2^l ((l/2)!)²)``.
    Values: ``π, 2π/3, π/4, 0, -π/24, …``; unit: sr.
    """
    lmax = check_lmax(lmax)
    k = np.zeros(lmax + 1)
    k[0] = np.pi
    if lmax >= 1:
        k[1] = 2.0 * np.pi / 3.0
    for l in range(2, lmax + 1, 2):
        sign = 1.0 if (l // 2 - 1) % 2 == 0 else -1.0
        k[l] = 2.0 * np.pi * sign / ((l + 2) * (l - 1)) * _central_binomial_ratio(l // 2)
    return k


def kajiya_kay_kernel(lmax: int) -> np.ndarray:
    """Kajiya–Kay diffuse (tangent irradiance) kernel ``A_l``, ``l = 0 … lmax``.

    Mehta, Ramamoorthi, Meyer, Hery 2012, eq. 17 (normalised by ``1/π²`` so a
    white dome gives ``E ≡ 1``)::

        A_0 = 1,  odd A_l = 0,
        A_2n = -1/((n+1)(2n-1)) · ((2n)! / (2^n n!)²)²

    ``A_2 = -1/8``, ``A_4 = -1/64`` (the paper prints −0.01625 for ``A_4``: a
    typo, SPEC §4), ``A_6 = -5/1024``. Dimensionless.
    """
    lmax = check_lmax(lmax)
    k = np.zeros(lmax + 1)
    k[0] = 1.0
    for l in range(2, lmax + 1, 2):
        n = l // 2
        k[l] = -1.0 / ((n + 1) * (2 * n - 1)) * _central_binomial_ratio(n) ** 2
    return k


def vmf_kernel(lmax: int, kappa: float) -> np.ndarray:
    """Band factors ``exp(-l(l+1)/(2κ))`` of a von Mises–Fisher lobe (SPEC §4).

    The normalised vMF lobe of concentration ``κ`` (1/sr-free) has band
    factors close to this Gaussian form for ``κ ≳ 2`` (Silvennoinen et al.,
    eq. 11); used as a smoothing window.
    """
    lmax = check_lmax(lmax)
    if not np.isfinite(kappa) or kappa <= 0:
        raise ParameterError(f"kappa must be positive and finite, got {kappa}")
    l = np.arange(lmax + 1)
    return np.exp(-l * (l + 1) / (2.0 * kappa))


def convolve(coeffs, kernel) -> np.ndarray:
    """Multiply each band of ``coeffs`` (shape ``(n, ...)``) by ``kernel[l]``.

    ``kernel`` must have at least ``lmax + 1`` entries.
    """
    c = np.asarray(coeffs, dtype=np.float64)
    lmax = lmax_of(c.shape[0])
    k = np.asarray(kernel, dtype=np.float64)
    if k.shape[0] < lmax + 1:
        raise ParameterError(f"kernel has {k.shape[0]} bands, coefficients need {lmax + 1}")
    factors = k[band_of_index(lmax)]
    return c * factors.reshape((-1,) + (1,) * (c.ndim - 1))
