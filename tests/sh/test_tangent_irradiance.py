"""Tangent irradiance's closed forms (:mod:`shbake.sh.tangent_irradiance`, eq. 22 and 23)
against the brute-force integrator on a map band-limited to l ≤ 2, where they are exact.
"""

import numpy as np

from shbake.sh.tangent_irradiance import eval_matrix_form, matrix_form, six_term
from tests.references import QUERIES
from tests.references import brute_force_of_synthetic_map as brute


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
