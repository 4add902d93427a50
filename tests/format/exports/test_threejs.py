"""three.js exports (:mod:`shbake.format.exports.threejs`) read by three's ObjectLoader,
``LightProbe.getIrradianceAt`` and ``DirectionalLight`` under node (tests/engines): equal to
shbake's irradiance on every shared map, the probe's position carried, a wrong convention
failing; the engine's irradiance against brute force (reported).
"""

import json
import shutil

import numpy as np
import pytest

from shbake.batch.export import export_assets
from shbake.conventions import REC709_LUMINANCE
from shbake.evaluation.env_sh import brute_force_reference
from shbake.format.exports.source import load_source, shbake_irradiance
from tests.export_checks import BAKED_FOR_NODE, N_DIRS, TOL
from tests.export_checks import relative_error as _rel
from tests.helpers import run_node

pytestmark = BAKED_FOR_NODE


class TestThreejs:
    """threejs.write: three's ObjectLoader + LightProbe.getIrradianceAt + DirectionalLight."""

    def test_irradiance_equals_shbake(self, baked, dirs_file):
        r = run_node("three_irradiance.mjs", baked["three"], dirs_file)
        got = np.array(r["irradiance"])
        src = load_source(baked["h5"])
        d = np.array(json.load(open(dirs_file)))
        want = shbake_irradiance(src, d)
        assert r["probes"] == 1 and r["lights"] == 3 * len(src.lights)
        print(
            f"\n{baked['name']}: three vs shbake {_rel(got, want, src, d):.2e} "
            f"(per-direction |E|: {_rel(got, want):.2e})"
        )
        assert _rel(got, want, src, d) < TOL

    @pytest.mark.parametrize(
        ("frame", "rotate", "want"),
        [("y-up", 0.0, [1.5, 2.0, -3.0]), ("z-up", 90.0, [1.5, 3.0, 2.0])],
    )
    def test_probe_position_reaches_three(self, sky_asset, dirs_file, frame, rotate, want):

        import h5py

        h5 = str(sky_asset["dir"] / f"pos-{frame}.h5")
        shutil.copy(sky_asset["h5"], h5)
        with h5py.File(h5, "r+") as f:
            f.attrs["probe_position"] = np.array([1.5, 2.0, -3.0])
        out = str(sky_asset["dir"] / f"pos-{frame}.json")
        export_assets([h5], "threejs", out, frame=frame, rotate_deg=rotate)
        r = run_node("three_irradiance.mjs", out, dirs_file)
        # z-up: (x, y, z) -> (x, -z, y); --rotate turns the environment, not the probe
        assert r["positions"] == [want]
        src = load_source(h5, frame=frame, rotate_deg=rotate)
        want_e = shbake_irradiance(src, np.array(json.load(open(dirs_file))))
        assert _rel(np.array(r["irradiance"]), want_e) < TOL  # the sun does not move with it
        unity = json.load(open(export_assets([h5], "unity", out[:-5] + ".unity.json",
                                             frame=frame, rotate_deg=rotate)[0]))  # fmt: skip
        assert unity["position"] == [-want[0], want[1], want[2]]  # Unity: x mirrored

    @pytest.mark.parametrize("fault", ["irradiance-sh", "flip-x", "pi"])
    def test_a_wrong_convention_fails(self, baked, dirs_file, fault):
        doc = json.load(open(baked["three"]))
        probe = doc["object"]["children"][0]
        c = np.array(probe["sh"]).reshape(9, 3)
        if fault == "irradiance-sh":  # the cosine kernel applied twice
            c *= np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)[:, None]
        elif fault == "flip-x":
            c[[3, 4, 7]] *= -1
        else:
            c /= np.pi
        probe["sh"] = c.reshape(-1).tolist()
        bad = str(baked["dir"] / "bad.json")
        with open(bad, "w") as f:
            json.dump(doc, f)
        got = np.array(run_node("three_irradiance.mjs", bad, dirs_file)["irradiance"])
        want = shbake_irradiance(load_source(baked["h5"]), np.array(json.load(open(dirs_file))))
        assert _rel(got, want) > 1e-3


class TestAgainstBruteForce:
    """Engine irradiance vs brute-force quadrature of the original map (reported)."""

    def test_report(self, baked, dirs_file):
        ref = brute_force_reference(baked["env"], n_dirs=N_DIRS)
        got = np.array(run_node("three_irradiance.mjs", baked["three"], dirs_file)["irradiance"])
        y = got @ REC709_LUMINANCE
        rel = np.abs(y - ref["irradiance"]) / np.maximum(ref["irradiance"], 1e-30)
        print(
            f"\n{baked['name']}: engine vs brute force "
            f"luminance mean {rel.mean():.3%} max {rel.max():.3%}"
        )
        assert np.all(np.isfinite(rel))
