"""Baking a planned scene's assets (``shbake/batch/scene_bake.py``): what one asset's bake
and check compute."""

import json
import shutil

import numpy as np
import pytest

from shbake.batch.scene import load_scene
from shbake.batch.scene_bake import bake_scene
from shbake.envmap.turn import turn_matrix
from shbake.evaluation.env_sh import check_reference, irradiance_errors
from shbake.format import provenance
from shbake.format.asset import read_asset
from tests.helpers import DIFFUSE_SCENE, map_path

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


def same_bytes_planned_or_made(tmp_path, planned, scene_in, owner, name, ids,
                               monkeypatch) -> None:  # fmt: skip
    """Bake scene ``planned`` (in ``tmp_path / "planned"``, planned already) with
    ``owner.name`` refused — the bake writes what its plan made — and
    ``scene_in(tmp_path / "made")`` with no plan unit given to its assets (the bake makes
    each itself); assets ``ids`` have the same bytes in both."""
    from shbake.batch import scene_bake

    def refuse(*args, **kwargs):
        raise AssertionError(f"the bake called {name} again")

    with monkeypatch.context() as m:
        m.setattr(owner, name, refuse)
        bake_scene(planned)
    made = scene_in(tmp_path / "made")
    with monkeypatch.context() as m:
        m.setattr(scene_bake, "_with_planned", lambda asset, units: asset)
        bake_scene(made)
    for aid in ids:
        got = (tmp_path / "planned" / "out" / f"{aid}.h5").read_bytes()
        assert got == (tmp_path / "made" / "out" / f"{aid}.h5").read_bytes(), aid


GLOSSY_SCENE = """[scene]
out_dir = "out"
[tolerances]
glossy_probe = 0.99
[[environments]]
map = "maps/*.exr"
[[materials]]
name = "varnish"
kind = "glossy"
roughness = [0.5, 0.9]
"""


class TestPlannedFit:
    """``bake_scene`` writes the SH-exp fit its plan made (issue 31: the bake fitted each map
    a second time)."""

    def _scene(self, folder, text=GLOSSY_SCENE):
        (folder / "maps").mkdir(parents=True)
        for name in ("studio", "sunset"):
            shutil.copy(map_path(name), folder / "maps" / f"{name}.exr")
        (folder / "scene.toml").write_text(text)
        return load_scene(str(folder / "scene.toml"))

    def test_same_bytes_as_fitting_in_the_bake_and_no_second_fit(self, tmp_path, monkeypatch):
        from shbake.bakers.shexp import FitPlan
        from shbake.batch.plan import plan_scene_kept

        planned = self._scene(tmp_path / "planned")
        plan = plan_scene_kept(planned)
        ids = sorted(a["id"] for a in plan["assets"])
        assert ids == ["shexp/studio", "shexp/sunset"]
        same_bytes_planned_or_made(tmp_path, planned, self._scene, FitPlan, "fit_many", ids,
                                   monkeypatch)  # fmt: skip
        lock = json.loads((tmp_path / "planned" / "out" / "scene.lock.json").read_text())
        for a in plan["assets"]:
            aid = a["id"]
            # predicted and measured: the same fit's residual
            assert lock["assets"][aid]["measured_error"] == a["predicted_error"], aid

    def test_a_turned_probe_and_other_kinds_are_fitted_in_the_bake(self):
        from shbake.batch.scene_bake import _with_planned

        units = {"k": {"fit": {"p": "x"}}}
        shexp = {"kind": "shexp", "plan_key": "k", "settings": {}}
        assert _with_planned(shexp, units)["planned_fit"] == {"p": "x"}
        for rotation, planned in ((0.0, True), (360.0, True), (30.0, False)):
            a = dict(shexp, settings={"pose": {"position": [0, 0, 0], "rotation_deg": rotation}})
            assert ("planned_fit" in _with_planned(a, units)) is planned, rotation
        assert "planned_fit" not in _with_planned(dict(shexp, kind="splitsum"), units)
        assert "planned_fit" not in _with_planned(dict(shexp, plan_key="other"), units)


SUN_SCENE = (
    DIFFUSE_SCENE
    + """[[environments]]
map = "maps/studio.exr"
name = "turned"
rotation_deg = 30.0
"""
)


def overcast() -> np.ndarray:
    """A 32 × 64 map without a compact light (its peak under 20× the background)."""
    rng = np.random.default_rng(3)
    return (0.5 + 0.5 * rng.random((32, 64, 3))).astype(np.float32)


class TestPlannedProjection:
    """``bake_scene`` writes the env_sh projection (sun extracted) its plan made (issue 31:
    the bake extracted each map's sun and projected it a second time)."""

    def _scene(self, folder):
        from tests.helpers import write_test_exr

        (folder / "maps").mkdir(parents=True)
        for name in ("studio", "sunset"):  # a sun extracted from each
            shutil.copy(map_path(name), folder / "maps" / f"{name}.exr")
        written = folder.parent / "overcast.exr"  # one file: an EXR records when it was written
        if not written.exists():
            write_test_exr(written, overcast())
        shutil.copy(written, folder / "maps" / "overcast.exr")  # no sun
        (folder / "scene.toml").write_text(SUN_SCENE)
        return load_scene(str(folder / "scene.toml"))

    def test_same_bytes_as_projecting_in_the_bake_and_none_there(self, tmp_path, monkeypatch):
        from shbake.bakers import env_sh
        from shbake.batch.plan import plan_scene_kept

        planned = self._scene(tmp_path / "planned")
        plan = plan_scene_kept(planned)
        suns = {a["id"]: a["settings"]["extract_sun"] for a in plan["assets"]}
        assert len(suns) == 4 and True in suns.values() and False in suns.values(), suns
        same_bytes_planned_or_made(tmp_path, planned, self._scene, env_sh, "project_lighting",
                                   suns, monkeypatch)  # fmt: skip

    def test_fitted_lights_and_other_kinds_are_projected_in_the_bake(self):
        from shbake.batch.scene_bake import _with_planned

        units = {"k": {"projection": {"sh": "x"}}}
        env_sh = {"kind": "env_sh", "plan_key": "k", "settings": {"lmax": 2}}
        assert _with_planned(env_sh, units)["planned_projection"] == {"sh": "x"}
        turned = dict(env_sh, settings={"lmax": 2, "pose": {"position": [0, 0, 0],
                                                            "rotation_deg": 30.0}})  # fmt: skip
        assert "planned_projection" in _with_planned(turned, units)  # the SH are turned after
        lit = dict(env_sh, settings={"lmax": 2, "lights": 2})
        assert "planned_projection" not in _with_planned(lit, units)
        assert "planned_projection" not in _with_planned(dict(env_sh, kind="shexp"), units)
        assert "planned_projection" not in _with_planned(dict(env_sh, plan_key="other"), units)


class TestProjectionRecord:
    """``Projection.to_record`` / ``from_record``: exact, and untrusted records refused."""

    @pytest.fixture(scope="class", params=["sun", "no sun", "not extracted"])
    @classmethod
    def projection(cls, request):
        from shbake.bakers.env_sh import project_lighting
        from shbake.envmap import load_environment
        from shbake.envmap.environment import Environment

        if request.param == "not extracted":
            env = Environment(overcast(), "latlong")
        else:
            env = load_environment(str(map_path("sunset")), quiet=True)
        radius = None if request.param == "no sun" else 10.0
        return project_lighting(env, 3, radius)

    def test_round_trip_is_exact(self, projection):
        from shbake.bakers.env_sh import Projection

        rec = json.loads(json.dumps(projection.to_record()))
        back = Projection.from_record(rec, 3, projection.sun_radius_deg)
        assert np.array_equal(back.sh, projection.sh)
        assert back.sun_report == projection.sun_report
        assert (back.light is None) is (projection.light is None)
        if back.light is not None:
            assert np.array_equal(back.light.direction, projection.light.direction)
            assert np.array_equal(back.light.radiance, projection.light.radiance)
            assert back.light.solid_angle == projection.light.solid_angle

    @pytest.mark.parametrize("spoil", ["lmax", "radius", "short", "base64", "nan", "key",
                                       "light", "norm", "report", "bool", "extracted"])  # fmt: skip
    def test_not_a_record_of_these_settings(self, projection, spoil):
        import base64

        from shbake.bakers.env_sh import Projection

        rec = json.loads(json.dumps(projection.to_record()))
        lmax, radius = 3, projection.sun_radius_deg
        if spoil == "lmax":
            lmax = 2
        elif spoil == "radius":
            radius = 5.0 if radius is None else None
        elif spoil == "short":
            rec["sh"] = base64.b64encode(base64.b64decode(rec["sh"])[:-8]).decode()
        elif spoil == "base64":
            rec["sh"] = "not base64!"
        elif spoil == "nan":
            rec["sh"] = base64.b64encode(np.full((16, 3), np.nan).tobytes()).decode()
        elif spoil == "key":
            rec["extra"] = 1
        elif spoil == "light":
            rec["light"] = {"direction": [0.0, 0.0, 1.0], "solid_angle": 0.1}
        elif spoil == "norm":
            rec["light"] = {"direction": [0.0, 0.0, 2.0], "solid_angle": 0.1,
                            "radiance": [1.0, 1.0, 1.0]}  # fmt: skip
        elif spoil == "report":
            rec["sun_report"] = {"extracted": False, "peak_luminance": "1"}
        elif spoil == "bool":
            rec["sun_report"] = dict(rec["sun_report"] or {}, extracted=1)
        else:  # a light without an extraction, or an extraction without its light
            report = rec["sun_report"] or {"peak_luminance": 1.0, "background": [0.0] * 3,
                                           "contrast": 1.0}  # fmt: skip
            rec["sun_report"] = dict(report, extracted=not report.get("extracted", False))
        assert Projection.from_record(rec, lmax, radius) is None
        assert Projection.from_record(None, 3, projection.sun_radius_deg) is None


class TestProbeRecord:
    """``ShexpProbe.to_record`` / ``from_record``: exact, and untrusted records refused."""

    @pytest.fixture(scope="class")
    @classmethod
    def fitted(cls):
        from shbake.bakers.shexp import FitConfig
        from shbake.batch.probe_jobs import fit_plan
        from shbake.envmap import load_environment

        config = FitConfig.paper(alpha_min=0.25, alpha_max=0.81, samples=256)
        env = load_environment(str(map_path("sunset")), quiet=True)
        return config, fit_plan(config, env.shape).fit(env.pixels)

    def test_round_trip_is_exact(self, fitted):
        from shbake.bakers.shexp import ShexpProbe

        config, probe = fitted
        back = ShexpProbe.from_record(json.loads(json.dumps(probe.to_record())), config)
        for k in ("p", "q", "knots"):
            assert np.array_equal(getattr(back, k), getattr(probe, k)), k
        assert back.stats == probe.stats

    @pytest.mark.parametrize("spoil", ["short", "base64", "nan", "key", "stats", "bool", "alpha"])
    def test_not_a_record_of_this_fit(self, fitted, spoil):
        import base64

        from shbake.bakers.shexp import ShexpProbe

        config, probe = fitted
        rec = json.loads(json.dumps(probe.to_record()))
        if spoil == "short":
            rec["p"] = base64.b64encode(base64.b64decode(rec["p"])[:-8]).decode()
        elif spoil == "base64":
            rec["q"] = "not base64!"
        elif spoil == "nan":
            rec["knots"] = base64.b64encode(np.full(config.sets, np.nan).tobytes()).decode()
        elif spoil == "key":
            rec["extra"] = 1
        elif spoil == "stats":
            rec["stats"]["log_rms"] = "0.1"
        elif spoil == "bool":
            rec["stats"]["targets"] = True
        else:
            rec["stats"]["shaded_relative_rms_by_alpha"].append(0.1)
        assert ShexpProbe.from_record(rec, config) is None
        assert ShexpProbe.from_record(None, config) is None
