"""SHRM assets (:mod:`shbake.format.shrm`): a bake round-trips and is written byte-identically."""

import numpy as np

from shbake.bakers.shrm import bake_shrm
from shbake.brdf.reflection import make_reflection_brdf
from tests.shrm_cases import small_env


class TestAsset:
    def test_roundtrip_and_deterministic(self, tmp_path):
        from shbake.format.asset import read_asset
        from shbake.format.shrm import build_shrm_asset, read_shrm, write_shrm

        env = small_env("city", 64)
        bake = bake_shrm(env, make_reflection_brdf("microfacet", {"sigma": 0.3}), face_size=16)
        a, b = tmp_path / "a.h5", tmp_path / "b.h5"
        write_shrm(str(a), build_shrm_asset(bake, env.meta))
        write_shrm(str(b), build_shrm_asset(bake, env.meta))
        assert a.read_bytes() == b.read_bytes()
        asset = read_asset(str(a), kinds=("shrm",))
        shrm = read_shrm(str(a))
        assert shrm.F == bake.F and shrm.P == bake.P and shrm.face_size == 16
        np.testing.assert_array_equal(shrm.cube, bake.cube)
        assert asset.attrs["brdf_model"] == "microfacet"
