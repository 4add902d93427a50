"""Brute-force irradiance (:mod:`shbake.reference.irradiance`): convergence to the analytic
convolution of a band-limited map, the white dome. The closed forms it checks:
``tests/sh/test_tangent_irradiance.py``."""

import numpy as np
import pytest

from shbake.envmap.layouts import latlong_directions, latlong_solid_angles
from shbake.reference.irradiance import brute_force_irradiance
from shbake.sh.basis import real_sh
from shbake.sh.kernels import convolve, kajiya_kay_kernel, lambert_kernel
from tests.references import QUERIES
from tests.references import brute_force_of_synthetic_map as brute


class TestBruteForceIrradiance:
    @pytest.mark.parametrize("tangent", [False, True])
    def test_converges_to_the_analytic_convolution(self, tangent, random_coeffs):
        # A band-limited map (lmax 4, kept positive): E is known exactly from the kernels.
        c = random_coeffs(4, seed=7) * 0.1
        c[0] = 4.0
        K = kajiya_kay_kernel(4) if tangent else lambert_kernel(4)
        exact = real_sh(QUERIES, 4) @ convolve(c, K)
        errs = [np.abs(brute(c, h, tangent) - exact).max() for h in (32, 64, 128)]
        # Second order: each doubling divides the error by about 4 (3 allows for noise).
        assert errs[0] / errs[1] > 3 and errs[1] / errs[2] > 3
        assert errs[-1] < 2e-3 * np.abs(exact).max()

    def test_white_dome(self):
        d = latlong_directions(128, 256).reshape(-1, 3)
        w = latlong_solid_angles(128, 256).ravel()
        one = np.ones((d.shape[0], 3))
        np.testing.assert_allclose(brute_force_irradiance(d, w, one, QUERIES), np.pi, rtol=1e-4)
        np.testing.assert_allclose(
            brute_force_irradiance(d, w, one, QUERIES, tangent=True), 1.0, rtol=1e-4
        )
