"""Preview passes (:mod:`shbake.preview.passes`): analytic dome values, tangents along the longitude
lines. The command (agreement with brute force, outputs): ``tests/cli/test_preview.py``."""

import numpy as np

from shbake.format.asset import read_asset
from shbake.preview.passes import render_pass
from shbake.preview.sphere import sphere_geometry
from shbake.shading.shader import shader


class TestPasses:
    def test_white_dome_shades_to_albedo(self, dome_asset):
        a = read_asset(str(dome_asset))
        _, _, mask = sphere_geometry(32)
        img, _ = render_pass(shader(a, "irradiance"), 32)
        np.testing.assert_allclose(img[mask], 1.0, rtol=1e-9)  # Lambert ρ=1 → radiance 1
        img, _ = render_pass(shader(a, "tangent"), 32)
        np.testing.assert_allclose(img[mask], 1.0, rtol=1e-9)
        assert np.all(img[~mask] == 0)

    def test_tangents_follow_longitude_lines(self):
        n, t, mask = sphere_geometry(16)
        assert np.abs(np.sum(n * t, axis=-1)[mask]).max() < 1e-12
        assert np.all(t[mask][:, 1] >= 0)  # pointing toward +Y
