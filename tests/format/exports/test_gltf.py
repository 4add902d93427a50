"""glTF exports (:mod:`shbake.format.exports.gltf`) read by Babylon.js's own glTF loader under
node (tests/engines, ``npm ci``): its irradiance equals shbake's (SH + lights) at 300
directions on every shared map, plain, with ``--extract-sun`` and with ``--lights auto``; the
Khronos validator reports no error; a flipped axis, a π or Babylon's sign fails the check.
"""

import glob
import json
import shutil

import numpy as np
import pytest

from shbake.batch.export import export_assets
from shbake.format.exports.source import load_source, shbake_irradiance
from tests.export_checks import BAKED_FOR_NODE, SMALL, TOL
from tests.export_checks import relative_error as _rel
from tests.helpers import run_node

pytestmark = BAKED_FOR_NODE


class TestBabylonGltf:
    """gltf.write: Babylon.js's loader reads shbake's irradiance (sun included)."""

    def test_irradiance_equals_shbake(self, baked, dirs_file):
        r = run_node("babylon_irradiance.mjs", baked["gltf"], dirs_file)
        got = np.array(r["irradiance"])
        src = load_source(baked["h5"])
        d = np.array(json.load(open(dirs_file)))
        want = shbake_irradiance(src, d)
        assert r["lights"] == len(src.lights)
        print(
            f"\n{baked['name']}: Babylon vs shbake {_rel(got, want, src, d):.2e} "
            f"(per-direction |E|: {_rel(got, want):.2e})"
        )
        assert _rel(got, want, src, d) < TOL

    def test_validator_reports_no_error(self, baked):
        r = run_node("validate_gltf.mjs", baked["gltf"])
        assert r["numErrors"] == 0, r["messages"]

    def test_right_handed_babylon_scene(self, baked, dirs_file, tmp_path):
        """scene.useRightHandedSystem: the export made for it matches; the default one does not."""
        src = load_source(baked["h5"])
        d = np.array(json.load(open(dirs_file)))
        want = shbake_irradiance(src, d)
        rh = export_assets(
            [baked["h5"]], "gltf", str(tmp_path / "rh.gltf"), babylon_scene="right-handed", **SMALL
        )[0]
        got = np.array(run_node("babylon_irradiance.mjs", rh, dirs_file, "rh")["irradiance"])
        assert _rel(got, want, src, d) < TOL
        lh = np.array(
            run_node("babylon_irradiance.mjs", baked["gltf"], dirs_file, "rh")["irradiance"]
        )
        assert _rel(lh, want) > 1e-3

    @pytest.mark.parametrize("fault", ["flip-x", "flip-y", "flip-z", "pi", "no-sign"])
    def test_a_wrong_convention_fails(self, baked, dirs_file, fault):
        """The comparison is sensitive: a mirrored axis, a π or Babylon's sign ignored fails."""
        doc = json.load(open(baked["gltf"]))
        light = doc["extensions"]["EXT_lights_image_based"]["lights"][0]
        c = np.array(light["irradianceCoefficients"])
        odd = {"flip-x": [3, 4, 7], "flip-y": [1, 4, 5], "flip-z": [2, 5, 7]}
        if fault in odd:
            c[odd[fault]] *= -1
        elif fault == "pi":
            c *= np.pi
        else:
            c *= np.array([1, -1, 1, 1, -1, -1, 1, 1, 1])[:, None]
        light["irradianceCoefficients"] = c.tolist()
        bad = str(baked["dir"] / "bad.gltf")
        with open(bad, "w") as f:
            json.dump(doc, f)
        for png in glob.glob(str(baked["dir"] / "a_specular_*.png")):
            shutil.copy(png, png.replace("a_specular_", "bad_specular_"))
        for im in doc["images"]:
            im["uri"] = im["uri"].replace("a_specular_", "bad_specular_")
        with open(bad, "w") as f:
            json.dump(doc, f)
        got = np.array(run_node("babylon_irradiance.mjs", bad, dirs_file)["irradiance"])
        want = shbake_irradiance(load_source(baked["h5"]), np.array(json.load(open(dirs_file))))
        assert _rel(got, want) > 1e-3
