"""The SHRM check (:class:`shbake.evaluation.shrm.ShrmCheck`): a converged bake measures small
against brute-force shading.
"""

import pytest

from shbake.bakers.shrm import bake_shrm
from shbake.brdf.reflection import make_reflection_brdf
from tests.shrm_cases import small_env


class TestShrmCheck:
    """The check the scene bake and ``shrm --report`` measure by (issue 28: its lobe
    reference was divided by √(4π), so a converged phong-lobe SHRM measured a relative
    error energy of ~6.6)."""

    @pytest.mark.parametrize("brdf, params", [("phong-lobe", {"s": 8}), ("ggx", {"alpha": 0.5})])
    def test_converged_bake_measures_small(self, brdf, params):
        from shbake.evaluation.shrm import ShrmCheck
        from shbake.format.shrm import build_shrm_asset

        env = small_env("city", 32)
        rb = make_reflection_brdf(brdf, params)
        bake = bake_shrm(env, rb, eps=1e-4, face_size=32)
        check = ShrmCheck(env, rb, sphere=16)
        assert check.rel_energy(build_shrm_asset(bake, env.meta)) < 0.01
