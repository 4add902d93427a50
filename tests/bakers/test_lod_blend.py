"""The sharp levels of a cube chain refitted to an engine's blend between levels
(:mod:`shbake.bakers.lod_blend`), judged against brute force (:mod:`shbake.reference`), not
against the fit's own targets."""

import os

import numpy as np
import pytest

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap import load_environment
from tests.export_checks import SHARED


class TestBlendedLevels:
    """blended_levels: the levels an engine only reads blended, below the rough end."""

    def test_three_and_filament_chains(self):
        from shbake.bakers.lod_blend import blended_levels
        from shbake.format.exports import filament, three_pmrem
        from shbake.format.exports.cube_chain import level_of_roughness

        def levels_of(n, r_min):
            return blended_levels(n, "filament", 512, level_of_roughness(r_min, n, "filament"))

        # three, 512² → 4²: lod ≥ 0.62; levels of r 0, .074, .155, .244, .345 (next .465)
        assert levels_of(8, three_pmrem.MIN_ROUGHNESS) == range(0, 5)
        # Filament, 512² → 8²: lod ≥ 1.02, so level 0 is never read
        assert levels_of(7, filament.MIN_ROUGHNESS) == range(1, 5)

    def test_nothing_without_a_roughness_floor(self):
        from shbake.bakers.lod_blend import blended_levels

        assert len(blended_levels(8, "filament", 512, 0.0)) == 0


class TestFitLodBlend:
    """fit_lod_blend: the engine's blend of the refitted levels is nearer the GGX lobe of the
    roughness it reads at than the blend of exact levels, and never farther."""

    @staticmethod
    def sunny(shrink: int):
        """esplanade (its sun of 29 856) averaged ``shrink`` × ``shrink``."""
        from shbake.envmap.environment import Environment

        env = load_environment(os.path.join(SHARED, "hdri", "esplanade.exr"), quiet=True)
        h, w = env.pixels.shape[0] // shrink, env.pixels.shape[1] // shrink
        px = env.pixels.astype(np.float64).reshape(h, shrink, w, shrink, 3).mean(axis=(1, 3))
        return Environment(px.astype(np.float32), "latlong")

    @staticmethod
    def blend_p95(env, size: int, floor: int) -> tuple[float, float]:
        """p95 relative luminance error of three's blend of the exact and of the refitted
        chain, at 1000 directions, each at a lod three reads between its floor and level 2,
        against brute force of that lod's lobe (:func:`reference_radiance`)."""
        from shbake.bakers.cube_chain import prefilter_chain
        from shbake.conventions import ggx_alpha
        from shbake.format.exports.cube_chain import (
            level_of_roughness,
            read_chain,
            roughness_of_level,
        )
        from shbake.format.exports.three_pmrem import MIN_ROUGHNESS
        from shbake.reference.prefiltered import reference_radiance

        kw = {"size": size, "floor": floor, "mapping": "filament"}
        exact, _ = prefilter_chain(env, **kw)
        fitted, _ = prefilter_chain(env, **kw, min_roughness=MIN_ROUGHNESS)
        n = len(exact)
        rng = np.random.default_rng(1)
        d = rng.normal(size=(1000, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        lods = rng.uniform(level_of_roughness(MIN_ROUGHNESS, n, "filament"), 2.0, len(d))
        alphas = np.array([ggx_alpha(roughness_of_level(ell, n, "filament")) for ell in lods])
        want = reference_radiance(env, d, alphas) @ REC709_LUMINANCE
        p95 = [np.percentile(np.abs(read_chain(c, d, lods) @ REC709_LUMINANCE - want) / want, 95)
               for c in (exact, fitted)]  # fmt: skip
        print(f"\n{size}² → {floor}², p95: exact levels {p95[0]:.2%}, refitted {p95[1]:.2%}")
        return p95[0], p95[1]

    def test_blend_nearer_brute_force(self):
        """The map averaged to 256 × 128, a 128² → 4² chain."""
        exact, refitted = self.blend_p95(self.sunny(2), 128, 4)
        assert refitted < 0.7 * exact  # measured 30.3 → 16.5 %

    def test_never_farther_than_exact_levels(self):
        """The map averaged to 128 × 64, a 64² → 2² chain: here the combinations do not fit
        the blend better (refitted without the check, 35.3 → 58.1 %), so the exact levels
        are kept."""
        exact, refitted = self.blend_p95(self.sunny(4), 64, 2)
        assert refitted <= exact

    @pytest.mark.parametrize("value", [0.0, 1e5])
    def test_black_and_uniform_maps(self, value):
        """A black map (every target 0) and a uniform one of 1e5: the refitted chain holds the
        map's value (a degenerate least squares gives no NaN, no ringing)."""
        from shbake.bakers.cube_chain import prefilter_chain
        from shbake.envmap.environment import Environment
        from shbake.format.exports.three_pmrem import MIN_ROUGHNESS

        env = Environment(np.full((32, 64, 3), value, np.float32), "latlong")
        levels, _ = prefilter_chain(env, 16, 2, "filament", 32, min_roughness=MIN_ROUGHNESS)
        for level in levels:
            np.testing.assert_allclose(level, value, rtol=1e-12, atol=0.0)
