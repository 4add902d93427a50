"""glTF exports (:mod:`shbake.format.exports.gltf`) read by Babylon.js's own glTF loader under
node (tests/engines, ``npm ci``): its irradiance equals shbake's (SH + lights) at 300
directions on every shared map, plain, with ``--extract-sun`` and with ``--lights auto``; the
Khronos validator reports no error; a flipped axis, a π or Babylon's sign fails the check.
"""

import glob
import json
import os
import shutil

import numpy as np
import pytest

from shbake.batch.export import export_assets
from shbake.format.exports.source import load_source, shbake_irradiance
from tests.export_checks import BAKED_FOR_NODE, MAPS, SMALL, TOL
from tests.export_checks import relative_error as _rel
from tests.helpers import run_node

pytestmark = BAKED_FOR_NODE

FAULTS = ["flip-x", "flip-y", "flip-z", "pi", "no-sign"]


def babylon_reads(dirs_file: str, scene: str, *files: str) -> list[dict]:
    """What Babylon.js's own loader shades with at the directions of ``dirs_file``, for each
    glTF of ``files`` in a left- (``"lh"``) or right-handed (``"rh"``) scene: one node process
    for them all (``tests/engines/babylon_irradiance.mjs``)."""
    return run_node("babylon_irradiance.mjs", dirs_file, scene, *files)


def with_fault(gltf: str, fault: str) -> str:
    """A copy of ``gltf`` beside it (its images copied too) with the irradiance coefficients
    broken by ``fault``: an axis mirrored, times π, or Babylon's sign left out."""
    doc = json.load(open(gltf))
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
    folder, stem = os.path.dirname(gltf), f"bad-{fault}"
    for png in glob.glob(os.path.join(folder, "a_specular_*.png")):
        shutil.copy(png, png.replace("a_specular_", f"{stem}_specular_"))
    for im in doc["images"]:
        im["uri"] = im["uri"].replace("a_specular_", f"{stem}_specular_")
    bad = os.path.join(folder, f"{stem}.gltf")
    with open(bad, "w") as f:
        json.dump(doc, f)
    return bad


@pytest.fixture(scope="module")
def faulted(dirs_file):
    """``faulted(baked)``: fault → the irradiance Babylon.js reads from the asset's glTF so
    broken (the :data:`FAULTS` files of an asset written and loaded by one node process, once)."""
    runs = {}

    def get(baked: dict) -> dict:
        if baked["name"] not in runs:
            reads = babylon_reads(dirs_file, "lh", *(with_fault(baked["gltf"], f) for f in FAULTS))
            runs[baked["name"]] = {
                f: np.array(r["irradiance"]) for f, r in zip(FAULTS, reads, strict=True)
            }
        return runs[baked["name"]]

    return get


class TestBabylonGltf:
    """gltf.write: Babylon.js's loader reads shbake's irradiance (sun included)."""

    def test_irradiance_equals_shbake(self, baked, dirs_file):
        (r,) = babylon_reads(dirs_file, "lh", baked["gltf"])
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
        got, lh = (
            np.array(r["irradiance"]) for r in babylon_reads(dirs_file, "rh", rh, baked["gltf"])
        )
        assert _rel(got, want, src, d) < TOL
        assert _rel(lh, want) > 1e-3

    @pytest.mark.parametrize("fault", FAULTS)
    def test_a_wrong_convention_fails(self, baked, dirs_file, faulted, fault):
        """The comparison is sensitive: a mirrored axis, a π or Babylon's sign ignored fails."""
        got = faulted(baked)[fault]
        want = shbake_irradiance(load_source(baked["h5"]), np.array(json.load(open(dirs_file))))
        assert _rel(got, want) > 1e-3


@pytest.mark.parametrize("baked", [(MAPS[0], "")], indirect=True)
def test_image_uris_are_percent_encoded(baked, dirs_file, tmp_path):
    """A name with a space, "#", "?" and "%": the images' URIs are percent-encoded, so the
    validator and Babylon.js find every image (the raw name cut the URI at "#")."""
    weird = str(tmp_path / "we ird#%?.gltf")
    export_assets([baked["h5"]], "gltf", weird, **SMALL)
    uris = [im["uri"] for im in json.load(open(weird))["images"]]
    assert all(u.startswith("we%20ird%23%25%3F_specular_") for u in uris), uris
    r = run_node("validate_gltf.mjs", weird)
    assert r["numErrors"] == 0, r["messages"]
    (got,) = babylon_reads(dirs_file, "lh", weird)
    assert np.allclose(got["irradiance"], babylon_reads(dirs_file, "lh", baked["gltf"])[0][
        "irradiance"])  # fmt: skip

