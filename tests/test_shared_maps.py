"""The six shared maps: irradiance and tangent irradiance vs brute force (issue acceptance).

The figures in docs/BENCHMARKS.md (bench/irradiance_accuracy.py) are
asserted here: each measured mean/max relative error must reproduce the
reported one, and sun extraction must beat plain lmax 2 on mean irradiance
error wherever it finds a light.
"""

import json
from pathlib import Path

import pytest

from shbake.bakers.env_sh import bake_env_sh
from shbake.envmap import load_environment
from shbake.evaluation.env_sh import brute_force_reference, irradiance_errors
from tests.conftest import SHARED_MAPS, map_path

EXPECTED = json.loads((Path(__file__).parent / "irradiance_accuracy_expected.json").read_text())


@pytest.mark.parametrize("name", SHARED_MAPS)
def test_reported_errors_reproduce(name):
    env = load_environment(str(map_path(name)), quiet=True)
    ref = brute_force_reference(env)
    measured = {}
    for lmax in (2, 8):
        for sun in (False, True):
            asset, _ = bake_env_sh(env, lmax=lmax, irradiance_lmax=lmax, sun=sun)
            key = f"lmax{lmax}{'+sun' if sun else ''}"
            measured[key] = irradiance_errors(asset, env, ref)
            for q in ("irradiance", "tangent_irradiance"):
                for stat in ("mean", "max"):
                    assert measured[key][q][stat] == pytest.approx(
                        EXPECTED[name][key][q][stat], rel=1e-3
                    ), (key, q, stat)
    # lmax 8 is closer to the truth than lmax 2.
    assert measured["lmax8"]["irradiance"]["mean"] < measured["lmax2"]["irradiance"]["mean"]
    # Light + residual beats plain lmax 2 wherever a light is found.
    if EXPECTED[name]["lmax2+sun"]["sun_extracted"]:
        assert measured["lmax2+sun"]["irradiance"]["mean"] < measured["lmax2"]["irradiance"]["mean"]
