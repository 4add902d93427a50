"""The SH-exp fit's quadrature plan (:mod:`shbake.bakers.shexp_targets`): the importance
pyramid keeps the map's integral, the filtered targets against converged MIS estimates.
"""

import numpy as np
import pytest

from shbake.bakers.shexp import FitConfig, FitPlan
from shbake.reference.ggx import ggx_integrals
from tests.helpers import map_path, smooth_map


class TestQuadraturePlan:
    def test_pyramid_keeps_the_integral(self):
        """Each pyramid level integrates to the map's ``∫ L dω`` (solid-angle weights)."""
        from shbake.envmap.importance import latlong_pyramid, level_offsets, pyramid_levels
        from shbake.envmap.layouts import latlong_solid_angles

        img = smooth_map(64, sun=[50.0, 40.0, 30.0])
        shape = img.shape[:2]
        levels = pyramid_levels(shape)
        pyr = latlong_pyramid(img.reshape(-1, 3), shape, levels)
        offs = level_offsets(shape, levels)
        assert levels == 4  # 64 → 8 rows
        totals = [
            np.einsum("pc,p->c", pyr[offs[k] : offs[k + 1]].astype(float),
                      latlong_solid_angles(shape[0] >> k, shape[1] >> k).reshape(-1))
            for k in range(levels)
        ]  # fmt: skip
        np.testing.assert_allclose(totals, np.tile(totals[0], (levels, 1)), rtol=1e-5)

    # city in make test; the other maps repeat the study (make test-all)
    @pytest.mark.parametrize("name, bound", [
        pytest.param("city", 0.015, marks=pytest.mark.heavy),
        pytest.param("esplanade", 0.04, marks=pytest.mark.slow),
        pytest.param("studio", 0.15, marks=pytest.mark.slow),
    ])  # fmt: skip
    def test_fit_targets_match_converged_integrals(self, name, bound):
        """The filtered plan (1024 samples, bright texels as point lights) against the
        converged MIS estimate (65 536 + 65 536 samples): log RMS measured 0.0083 on city,
        0.021 on esplanade (a sun), 0.098 on studio (small lamps); without the point
        lights it was 0.17 and 0.42."""
        from shbake.envmap import load_environment

        pixels = load_environment(str(map_path(name)), quiet=True).pixels
        plan = FitPlan(FitConfig(normals=8, views=16), pixels.shape[:2])
        e0 = plan.targets.e0(pixels)
        ref, _ = ggx_integrals(pixels, plan.views, plan.normals, plan.alpha, 65536)
        assert np.sqrt(np.mean(np.log(e0 / ref) ** 2)) < bound
