"""The per-direction bound on any chain an engine reads by a linear blend between levels
(:func:`tests.engine_cases.blend_bound`, ``bench/engine_blend_floor.py``), checked against an
independent search and against a real chain (which can never beat it), and the claim
docs/BENCHMARKS.md makes with it: on studio no seven-level Filament chain renders every
roughness from its floor to 0.3 within 15 % at the 95th percentile of directions."""

import numpy as np
import pytest

from shbake.bakers.cube_chain import prefilter_chain
from shbake.conventions import REC709_LUMINANCE
from shbake.envmap import load_environment
from shbake.format.exports.cube_chain import read_chain
from shbake.sh.point_sets import fibonacci_sphere
from tests.engine_cases import (
    FILAMENT_CUBES,
    FILAMENT_MIN_ROUGHNESS,
    P95_TOL,
    blend_bound,
    bound_lods,
    chain_sizes,
    prefiltered_luminance,
)
from tests.helpers import map_path


class TestBlendBound:
    def test_a_blend_of_levels_is_met_exactly(self):
        lods, knots = np.linspace(1.1, 2.9, 25), np.arange(1, 4)
        hats = np.maximum(0.0, 1.0 - np.abs(lods[:, None] - knots[None]))
        assert blend_bound(lods, knots, hats @ np.array([0.5, 2.0, 7.0])) < 1e-9

    def test_agrees_with_a_grid_search(self):
        # lod⁴ (a GGX tail's α² at small r) on one level's span: the best blend of its two
        # ends, searched on a fine grid of the two level values
        lods, knots = np.linspace(1.0, 2.0, 13), np.arange(1, 3)
        target = lods**4
        v1, v2 = np.meshgrid(np.linspace(0.0, 4.0, 801), np.linspace(8.0, 20.0, 801))
        reads = v1[..., None] * (2.0 - lods) + v2[..., None] * (lods - 1.0)
        searched = (np.abs(reads - target) / target).max(-1).min()
        bound = blend_bound(lods, knots, target)
        assert bound <= searched + 1e-12
        assert searched - bound < 2e-3
        assert bound > 0.1  # the tail no two levels blend to


@pytest.mark.slow
class TestStudioFilamentBound:
    def test_no_chain_of_seven_levels_meets_15_percent(self):
        env = load_environment(str(map_path("studio")), quiet=True)
        levels = len(chain_sizes(FILAMENT_CUBES))
        lods, knots = bound_lods(FILAMENT_MIN_ROUGHNESS, levels, 0.3)
        look = fibonacci_sphere(1500)
        target = prefiltered_luminance(env, look, lods, levels)
        bound = np.array([blend_bound(lods, knots, t) for t in target])
        assert np.mean(bound > P95_TOL) > 0.05
        # the chain the tests render is one such chain: at no direction does it beat the bound
        chain, _ = prefilter_chain(env, FILAMENT_CUBES["size"], FILAMENT_CUBES["floor"],
                                   "filament", FILAMENT_CUBES["samples"],
                                   min_roughness=FILAMENT_MIN_ROUGHNESS)  # fmt: skip
        reads = np.stack([read_chain(chain, look, lod) @ REC709_LUMINANCE for lod in lods], 1)
        worst = (np.abs(reads - target) / target).max(-1)
        assert np.all(worst >= bound - 1e-6)
