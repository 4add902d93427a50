"""The DFG (directional albedo) table (:mod:`shbake.bakers.dfg`) against a dense
Gauss–Legendre hemisphere quadrature of the GGX BRDF; its look-up exact at the nodes.
"""

import numpy as np
import pytest

from shbake.bakers.dfg import dfg_axes, dfg_table
from shbake.brdf import make_brdf
from shbake.shading.dfg import dfg_lookup
from tests.references import albedo_quadrature


class TestAlbedoTable:
    def test_nodes_match_dense_quadrature(self):
        table = dfg_table(size=8, samples=8192)
        mu, r = dfg_axes(8)
        for i in (1, 4, 7):
            for j in (2, 5, 7):
                v = np.array([np.sqrt(1 - mu[i] ** 2), 0.0, mu[i]])
                brdf = make_brdf("ggx", F0=1.0, alpha=r[j] ** 2)
                tail = make_brdf("ggx", F0=0.0, alpha=r[j] ** 2)
                assert table[i, j, 0] == pytest.approx(albedo_quadrature(brdf, v, 768)[0], abs=3e-3)
                assert table[i, j, 1] == pytest.approx(albedo_quadrature(tail, v, 768)[0], abs=3e-3)

    def test_lookup_is_exact_at_nodes(self):
        table = dfg_table(size=8, samples=512)
        mu, r = dfg_axes(8)
        np.testing.assert_allclose(dfg_lookup(table, mu[3], r[5] ** 2), table[3, 5], atol=1e-12)
