"""``shbake/bakers/brdf_table_report.py``: the energy ``∫ f*²`` every brdf-table error is
relative to, against its closed form."""

import numpy as np
import pytest

from shbake.bakers.brdf_table_report import product_energy
from shbake.brdf import make_brdf


class TestProductEnergy:
    @pytest.mark.parametrize("n", [0.0, 20.0, 1e4, 1e6])
    def test_normalised_phong_at_normal_view(self, n):
        """View along the normal: ``f* = (n+2)/(2π) cos^(n+1) θ``, so ``∫ f*² dω =
        (n+2)² / (2π (2n+3))``. A rule about the normal gave 0 at n = 10⁶ (the lobe fell
        between its nodes), and a brdf-table error of 1e147."""
        brdf = make_brdf("phong", n=str(n))
        got = product_energy(brdf, np.array([[0.0, 0.0, 1.0]]), 256)[0]
        want = (n + 2.0) ** 2 / (2.0 * np.pi * (2.0 * n + 3.0))
        np.testing.assert_allclose(got, want, rtol=1e-6)
