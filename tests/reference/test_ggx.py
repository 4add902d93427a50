"""The GGX ground truth ``E0`` (:mod:`shbake.reference.ggx`) against a dense Gauss–Legendre
hemisphere quadrature of the BRDF (``tests.references.albedo_quadrature``) and the
brute-force texel sum of :mod:`shbake.reference.brdf_shading` (SPEC §5); against Mitsuba 3:
``tests/reference/test_ggx_mitsuba.py``.
"""

import numpy as np
import pytest

from shbake.brdf import make_brdf
from shbake.brdf.sampling import tangent_frame
from shbake.envmap.layouts import latlong_directions
from shbake.reference.brdf_shading import brute_force_shading
from shbake.reference.ggx import ggx_integrals
from tests.helpers import smooth_map
from tests.probe_cases import random_pairs
from tests.references import albedo_quadrature


class TestGgxIntegrals:
    @pytest.mark.parametrize("r", [0.25, 0.5, 1.0])
    def test_white_map_gives_directional_albedo(self, r):
        brdf = make_brdf("ggx", F0=1.0, alpha=r * r)
        mu = np.array([0.05, 0.3, 0.7, 1.0])
        views = np.stack([np.sqrt(1 - mu**2), np.zeros(4), mu], 1)
        e0, _ = ggx_integrals(np.ones((8, 16, 3)), views, np.tile([0, 0, 1.0], (4, 1)), r * r,
                              8192)  # fmt: skip
        ref = np.array([albedo_quadrature(brdf, v, 1024)[0] for v in views])
        np.testing.assert_allclose(e0[:, 0], ref, atol=2e-3)

    def test_converges_to_brute_force_texel_sum(self):
        # 256x128: the texel-centre sum's own discretisation error is well below 1e-3 here
        img = smooth_map(128)
        h, w = img.shape[:2]
        v, n = random_pairs(12, 5)
        d = latlong_directions(h, w).reshape(-1, 3)
        from shbake.envmap.layouts import latlong_solid_angles

        omega = latlong_solid_angles(h, w).reshape(-1)
        frames = np.array([np.array([*tangent_frame(*nn), nn]) for nn in n])
        views_local = np.einsum("pij,pj->pi", frames, v)
        r = 0.5
        bf = brute_force_shading(d, omega, img.reshape(-1, 3), frames, views_local,
                                 make_brdf("ggx", F0=1.0, alpha=r * r))  # fmt: skip
        errs = [
            np.abs(ggx_integrals(img, v, n, r * r, s)[0] / bf - 1).max() for s in (256, 4096, 65536)
        ]
        assert errs[2] < errs[1] < errs[0] and errs[2] < 1e-3, errs

    def test_sun_of_1e5_converges(self):
        """A one-texel sun of 1e5 (99.9 % of the energy): the map's own samples find it, so
        4096 samples agree with 2^17 to 2e-3 at every GGX width (BRDF samples alone
        would hit the texel a handful of times)."""
        img = smooth_map(64, sun=[1e5, 1e5, 1e5])
        v, n = random_pairs(24, 9)
        for r in (0.04, 0.25, 1.0):
            coarse, _ = ggx_integrals(img, v, n, r, 4096)
            fine, _ = ggx_integrals(img, v, n, r, 1 << 17)
            np.testing.assert_allclose(coarse, fine, rtol=2e-3)

    def test_bad_geometry_refused(self):
        with pytest.raises(ValueError, match="above its surface"):
            ggx_integrals(np.ones((8, 16, 3)), [[0, 0, -1.0]], [[0, 0, 1.0]], 0.5)
        for bad in (1.5, 0.0, np.nan):
            with pytest.raises(ValueError, match="alpha"):
                ggx_integrals(np.ones((8, 16, 3)), [[0, 0, 1.0]], [[0, 0, 1.0]], bad)
