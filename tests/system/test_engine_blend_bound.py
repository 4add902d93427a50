"""``bench/engine_blend_floor.py``: the per-direction bound on any chain read by an engine's
linear blend between levels, checked against an independent search and against a real chain
(which can never beat it), and the claim docs/BENCHMARKS.md makes with it: on studio, no
seven-level Filament chain can render every roughness from its floor to 0.3 within 15 % at
the 95th percentile of the mirror sphere's directions."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
import engine_blend_floor as blend_floor  # noqa: E402

from shbake.bakers.cube_chain import prefilter_chain  # noqa: E402
from shbake.conventions import REC709_LUMINANCE  # noqa: E402
from shbake.envmap import load_environment  # noqa: E402
from shbake.format.exports.cube_chain import read_chain  # noqa: E402
from tests.engine_cases import FILAMENT_CUBES, FILAMENT_MIN_ROUGHNESS  # noqa: E402
from tests.helpers import map_path  # noqa: E402


def _hats(lods, knots):
    return np.maximum(0.0, 1.0 - np.abs(lods[:, None] - knots[None]))


class TestDirectionBound:
    def test_a_blend_of_levels_is_met_exactly(self):
        lods, knots = np.linspace(1.1, 2.9, 25), np.arange(1, 4)
        target = _hats(lods, knots) @ np.array([0.5, 2.0, 7.0])
        assert blend_floor.direction_bound(_hats(lods, knots), target) < 1e-9

    def test_agrees_with_a_grid_search(self):
        # lod⁴ (a GGX tail's α² at small r) on one level's span: the best blend of its two
        # ends, searched on a fine grid of the two level values
        lods, knots = np.linspace(1.0, 2.0, 13), np.arange(1, 3)
        target = lods**4
        v1, v2 = np.meshgrid(np.linspace(0.0, 4.0, 801), np.linspace(8.0, 20.0, 801))
        reads = v1[..., None] * (2.0 - lods) + v2[..., None] * (lods - 1.0)
        searched = (np.abs(reads - target) / target).max(-1).min()
        bound = blend_floor.direction_bound(_hats(lods, knots), target)
        assert bound <= searched + 1e-12
        assert searched - bound < 2e-3
        assert bound > 0.1  # the tail no two levels blend to


@pytest.mark.slow
class TestStudioFilamentBound:
    def test_no_chain_of_seven_levels_meets_15_percent(self):
        env = load_environment(str(map_path("studio")), quiet=True)
        levels = int(np.log2(FILAMENT_CUBES["size"] // FILAMENT_CUBES["floor"])) + 1
        lods, knots = blend_floor.lod_range("filament", levels, 0.3)
        look = blend_floor.mirror_directions("filament", levels)
        target = blend_floor.prefiltered_luminance(env, look, lods, levels)
        bound = np.array([blend_floor.direction_bound(_hats(lods, knots), t) for t in target])
        assert np.mean(bound > blend_floor.BOUND) > 0.05
        # the chain the tests render is one such chain: at no direction does it beat the bound
        chain, _ = prefilter_chain(env, FILAMENT_CUBES["size"], FILAMENT_CUBES["floor"],
                                   "filament", FILAMENT_CUBES["samples"],
                                   min_roughness=FILAMENT_MIN_ROUGHNESS)  # fmt: skip
        reads = np.stack([read_chain(chain, look, lod) @ REC709_LUMINANCE for lod in lods], 1)
        worst = (np.abs(reads - target) / target).max(-1)
        assert np.all(worst >= bound - 1e-6)
