"""Brute-force integrators: convergence, analytic values, and the closed forms they check."""

import numpy as np
import pytest

from shbake.envmap.layouts import latlong_directions, latlong_solid_angles
from shbake.reference.irradiance import brute_force_irradiance
from shbake.sh.basis import real_sh
from shbake.sh.kernels import convolve, kajiya_kay_kernel, lambert_kernel
from shbake.sh.tangent_irradiance import eval_matrix_form, matrix_form, six_term
from tests.helpers import synth_latlong

QUERIES = np.array([[0, 0, 1.0], [0, 1.0, 0], [0.6, -0.48, 0.64], [-1.0, 0, 0]])


def brute(coeffs, h, tangent):
    img = synth_latlong(coeffs, h)
    d = latlong_directions(h, 2 * h).reshape(-1, 3)
    w = latlong_solid_angles(h, 2 * h).ravel()
    return brute_force_irradiance(d, w, img.reshape(-1, 3), QUERIES, tangent=tangent)


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


class TestTangentClosedForms:
    def test_eq22_and_eq23_match_brute_force(self, random_coeffs):
        # A map band-limited to l <= 2: the 6-term forms are then exact.
        c = random_coeffs(2, seed=8) * 0.2
        c[0] = 3.0
        ref = brute(c, 256, tangent=True)
        t = QUERIES / np.linalg.norm(QUERIES, axis=1)[:, None]
        np.testing.assert_allclose(six_term(c, t), ref, rtol=2e-4)
        np.testing.assert_allclose(eval_matrix_form(matrix_form(c), t), ref, rtol=2e-4)

    def test_dome_gives_one(self):
        c = np.zeros((9, 1))
        c[0] = np.sqrt(4 * np.pi)
        np.testing.assert_allclose(six_term(c, QUERIES[:1]), 1.0, rtol=1e-15)
        np.testing.assert_allclose(eval_matrix_form(matrix_form(c), QUERIES[:1]), 1.0, rtol=1e-15)
