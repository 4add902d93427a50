"""Zonal kernels (:mod:`shbake.sh.kernels`) vs independent numerical quadrature (Funk–Hecke)."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import eval_legendre

from shbake.sh.kernels import convolve, kajiya_kay_kernel, lambert_kernel, vmf_kernel


def funk_hecke(k, l):
    """K_l = 2π ∫_{-1}^{1} k(t) P_l(t) dt by adaptive quadrature."""
    val, _ = quad(lambda t: k(t) * eval_legendre(l, t), -1, 1, limit=200, epsabs=1e-13)
    return 2 * np.pi * val


class TestLambertKernel:
    def test_spec_values(self):
        np.testing.assert_allclose(
            lambert_kernel(4), [np.pi, 2 * np.pi / 3, np.pi / 4, 0, -np.pi / 24], atol=1e-15
        )

    def test_matches_quadrature(self):
        k = lambert_kernel(12)
        for l in range(13):
            assert k[l] == pytest.approx(funk_hecke(lambda t: max(t, 0.0), l), abs=1e-10)


class TestKajiyaKayKernel:
    def test_a4_is_minus_one_64th_not_the_papers_typo(self):
        k = kajiya_kay_kernel(10)
        assert k[4] == pytest.approx(-1 / 64, rel=1e-15)
        np.testing.assert_allclose(
            k[[0, 2, 6, 8, 10]], [1, -1 / 8, -5 / 1024, -35 / 16384, -147 / 131072]
        )
        assert np.all(k[1::2] == 0)

    def test_matches_quadrature_of_eq_9(self):
        # A_l = (2/π) ∫_0^π P_l(cos θ) sin² θ dθ  (Mehta et al. eq. 9)
        k = kajiya_kay_kernel(16)
        for l in range(17):
            v, _ = quad(
                lambda th, l=l: eval_legendre(l, np.cos(th)) * np.sin(th) ** 2,
                0,
                np.pi,
                epsabs=1e-13,
            )
            assert k[l] == pytest.approx(2 / np.pi * v, abs=1e-11)

    def test_finite_at_lmax_128(self):
        assert np.all(np.isfinite(kajiya_kay_kernel(128)))
        assert np.all(np.isfinite(lambert_kernel(128)))


class TestConvolve:
    def test_scales_each_band(self):
        c = np.ones((9, 2))
        out = convolve(c, [1.0, 2.0, 3.0])
        np.testing.assert_allclose(out[:, 0], [1, 2, 2, 2, 3, 3, 3, 3, 3])

    def test_vmf(self):
        np.testing.assert_allclose(vmf_kernel(2, 3.0), np.exp(-np.array([0, 2, 6]) / 6.0))
