"""The angular baseline (:mod:`shbake.bakers.shrm_angular`): culling keeps every texel of the
appendix-D cap, agreement with the SHRM bake at high orders, the truncated surface BRDF
close to the full hemisphere.
"""

import numpy as np

from shbake.bakers.shrm import bake_shrm
from shbake.brdf.reflection import make_reflection_brdf
from shbake.sh.basis import real_sh
from shbake.texture.cube import cube_directions
from tests.shrm_cases import rel_rms, small_env


class TestAngularBaseline:
    def test_culling_keeps_every_texel_of_the_cap(self):
        from shbake.bakers.shrm_angular import angular_reflection_maps

        env = small_env("city", 64)
        dirs, om, rad = env.samples()
        R = cube_directions(8)
        R = R.reshape(-1, 3)
        s, eps = 128.0, 1e-12
        ct = eps ** (1 / (s + 1))  # appendix D: cos θ* = ε^{1/(s+1)}
        got = angular_reflection_maps(
            env.pixels, make_reflection_brdf("phong-lobe", {"s": s}), R, [[0, 0, 1]], eps
        )[0]
        c = R @ dirs.T
        ref = ((s + 1) / (2 * np.pi) * np.where(c >= ct, c, 0.0) ** s * om) @ rad
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12 * ref.max())

    def test_microfacet_matches_shrm_at_high_orders(self):
        from shbake.bakers.shrm_angular import angular_reflection_maps

        env = small_env("city", 64)
        rb = make_reflection_brdf("microfacet", {"sigma": 0.3})
        R = cube_directions(8)
        R = R.reshape(-1, 3)
        views = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]])
        full = angular_reflection_maps(env.pixels, rb, R, views, eps=0.0)
        bake = bake_shrm(env, rb, F=24, P=6, face_size=8)
        for k in range(2):
            keep = R @ views[k] > -0.5  # away from grazing (R ≈ −V)
            fr = bake.cube.reshape(len(R), -1, 3).astype(float).transpose(0, 2, 1) @ real_sh(
                views[k], 6
            )
            assert rel_rms(fr[keep], full[k][keep]) < 0.01

    def test_truncated_surface_brdf_close_to_the_full_hemisphere(self):
        """Appendix D's cap for a surface BRDF (``eps > 0``: ``truncation_angles`` from the
        ρ̂ grid) drops at most about ``eps`` of the reflected light; the full hemisphere
        (``eps = 0``) is the reference. Failed on main before the merge of issue 28: the
        ρ̂ grid kernel was called without its block bounds (TypeError)."""
        from shbake.bakers.shrm_angular import angular_reflection_maps

        env = small_env("city", 64)
        rb = make_reflection_brdf("microfacet", {"sigma": 0.3})
        R = cube_directions(8).reshape(-1, 3)
        views = np.array([[0.0, 0.0, 1.0]])
        full = angular_reflection_maps(env.pixels, rb, R, views, eps=0.0)[0]
        cut = angular_reflection_maps(env.pixels, rb, R, views, eps=0.01)[0]
        assert 0.0 < rel_rms(cut, full) < 0.02
