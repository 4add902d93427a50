"""The error of a cube chain as an engine reads it (:mod:`shbake.evaluation.cube_chain`).

That the read is the engine's own is shown against three.js itself in
``tests/system/test_engine_render.py`` (``TestThree::test_report_reads_the_chain_as_three_does``);
here: the read's arithmetic and orientation, and that the measure sees the faults a chain
can have.
"""

import numpy as np
import pytest

from shbake.bakers.cube_chain import prefilter_chain
from shbake.bakers.cube_prefilter import cube_directions
from shbake.envmap.environment import Environment
from shbake.evaluation.cube_chain import WARNING_P95, chain_errors, chain_warnings
from shbake.format.exports.cube_chain import read_chain
from tests.helpers import map_path


def _random_directions(n: int, seed: int = 0) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


class TestReadChain:
    """read_chain: the two levels around the lod, blended linearly; world directions."""

    def test_blends_the_two_levels_around_lod(self):
        levels = [np.full((6, 8 >> i, 8 >> i, 3), 2.0**i) for i in range(4)]
        d = _random_directions(5)
        np.testing.assert_allclose(read_chain(levels, d, 1.25), 0.75 * 2 + 0.25 * 4)
        np.testing.assert_allclose(read_chain(levels, d, -1.0), 1.0)  # clamped to the chain
        np.testing.assert_allclose(read_chain(levels, d, 7.0), 8.0)
        got = read_chain(levels, d[:2], [0.5, 3.0])
        np.testing.assert_allclose(got[:, 0], [1.5, 8.0])

    def test_reads_the_texel_showing_each_world_direction(self):
        """A level whose texels hold their own world direction reads back the direction
        asked for (bilinear across 32² texels: within 2e-3); an x mirror would read −x."""
        levels = [cube_directions(32)[0]]
        d = _random_directions(400, seed=1)
        got = read_chain(levels, d, 0.0)
        assert np.abs(got - d).max() < 2e-3


class TestChainErrors:
    """chain_errors: small for the chain as baked, large for a wrong lod rule or a flipped face
    (forest averaged to 128 × 64, a 64² to 2² chain: seconds)."""

    @pytest.fixture(scope="class")
    @classmethod
    def baked(cls):
        from shbake.envmap import load_environment

        env = load_environment(str(map_path("forest")), quiet=True)
        small = env.pixels.astype(np.float64).reshape(64, 4, 128, 4, 3).mean(axis=(1, 3))
        env = Environment(small.astype(np.float32), "latlong")
        levels, _ = prefilter_chain(env, size=64, floor=2, mapping="filament")
        return env, levels

    def test_sees_a_wrong_lod_rule_and_a_flipped_face(self, baked):
        env, levels = baked
        rough = (0.3, 0.6)
        right = chain_errors(env, levels, "filament", roughness=rough)
        wrong_rule = chain_errors(env, levels, "gltf-ibl-sampler", roughness=rough)
        flipped = [lv.copy() for lv in levels]
        for lv in flipped[1:]:
            lv[2] = lv[2, ::-1]
        flipped_face = chain_errors(env, flipped, "filament", roughness=rough)
        print(f"\nright {right}\nwrong rule {wrong_rule}\nflipped {flipped_face}")
        for good, bad, worse in zip(right, wrong_rule, flipped_face, strict=True):
            assert good["median"] < 0.06 and good["p95"] < 0.2
            assert bad["median"] > 2 * good["median"] and bad["p95"] > 2 * good["p95"]
            assert worse["p95"] > 2 * good["p95"]

    def test_reports_the_lod_the_engine_reads(self, baked):
        env, levels = baked
        (e,) = chain_errors(env, levels, "filament", roughness=(0.3,))
        assert e["roughness"] == 0.3
        assert e["lod"] == pytest.approx((len(levels) - 1) * 0.3 * 1.7)


class TestChainWarnings:
    """chain_warnings: one line naming each roughness above the bound, none below it."""

    def test_names_the_roughness_above_the_bound(self):
        errors = [{"roughness": 0.1, "p95": WARNING_P95 + 0.01, "median": 0.02},
                  {"roughness": 0.3, "p95": WARNING_P95 - 0.01, "median": 0.01}]  # fmt: skip
        (line,) = chain_warnings(errors)
        assert "at r 0.1" in line and "r 0.3" not in line and "--floor" in line
        assert chain_warnings(errors[1:]) == []
