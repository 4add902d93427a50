"""Baking a planned scene's assets (``shbake/batch/scene_bake.py``): what one asset's bake
and check compute."""

import json
import shutil

import pytest

from shbake.batch.scene import load_scene
from shbake.batch.scene_bake import bake_scene
from shbake.envmap.turn import turn_matrix
from shbake.evaluation.env_sh import check_reference, irradiance_errors
from shbake.format import provenance
from shbake.format.asset import read_asset
from tests.helpers import map_path

TURNED_SCENE = """[scene]
out_dir = "out"
[[environments]]
map = "maps/*.exr"
rotation_deg = 30.0
[[materials]]
name = "plaster"
kind = "diffuse"
"""


def test_env_sh_check_measures_the_map_the_bake_decoded(tmp_path, monkeypatch):
    """The env_sh check measures against the map the bake decoded (issue 31: it read the
    map again through ``reload_source`` — a SHA-256 of the file and a copy of its pixels):
    ``reload_source`` is never called, and each lock error equals the one measured afresh
    the way the check measured before — the asset read from its file, its map read back
    with the policies the asset records (negative pixels clamped: the shared maps have
    them), the probe turned by 30°."""
    (tmp_path / "maps").mkdir()
    for name in ("studio", "sunset"):
        shutil.copy(map_path(name), tmp_path / "maps" / f"{name}.exr")
    (tmp_path / "scene.toml").write_text(TURNED_SCENE)
    reload_source = provenance.reload_source

    def refuse(*args, **kwargs):
        raise AssertionError("the check read the map again")

    monkeypatch.setattr(provenance, "reload_source", refuse)
    bake_scene(load_scene(str(tmp_path / "scene.toml")))
    lock = json.loads((tmp_path / "out" / "scene.lock.json").read_text())
    assert set(lock["assets"]) == {"env_sh/studio", "env_sh/sunset"}
    for aid, rec in lock["assets"].items():
        path = str(tmp_path / "out" / f"{aid}.h5")
        asset = read_asset(path)
        assert asset.attrs["source_negative_count"] > 0
        env = reload_source(asset, path)
        ref = check_reference(env, ["irradiance"])
        fresh = irradiance_errors(asset, env, ref, rotation=turn_matrix(30.0))
        assert rec["settings"]["pose"]["rotation_deg"] == pytest.approx(30.0)
        assert rec["measured_error"] == {"irradiance": fresh["irradiance"]["relative_rms"]}, aid
