"""A scene probe's pose (:mod:`shbake.envmap.turn`, the scene bake): its rotation turns the
environment of every asset, its position is recorded.

Independent checks: the turn matrix against SciPy's rotation; a lat-long map turned by
columns against the SH rotation of its projection (Ivanic–Ruedenberg); a probe baked with
``rotation_deg`` against the same baker run on a map whose columns were rolled by numpy.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from shbake.batch.scene_bake import bake_asset
from shbake.envmap import load_environment
from shbake.envmap.environment import Environment
from shbake.envmap.image_io import read_image
from shbake.envmap.layouts import latlong_directions
from shbake.envmap.turn import apply_pose, turn_latlong, turn_matrix
from shbake.format.asset import read_asset
from shbake.sh.rotation import rotate
from tests.helpers import map_path, write_test_exr


class TestTurnMatrix:
    @pytest.mark.parametrize("deg", [0.0, 37.0, 90.0, -120.0])
    def test_is_scipys_turn_about_y(self, deg):
        ref = Rotation.from_euler("y", deg, degrees=True).as_matrix()
        np.testing.assert_allclose(turn_matrix(deg), ref, atol=1e-15)


class TestTurnLatlong:
    def test_exact_turn_is_the_sh_rotation(self):
        px, _ = read_image(str(map_path("sunset")))
        env = Environment(px, "latlong")
        turned = Environment(turn_latlong(px, 90.0), "latlong")
        want = rotate(env.project(6), turn_matrix(90.0))
        np.testing.assert_allclose(turned.project(6), want, atol=1e-6 * np.abs(want).max())

    def test_between_columns_interpolates(self):
        # a smooth map L(d) = 1 + d·a: its turn by 37° is L(Rᵀ d), to the interpolation error
        a = np.array([0.3, 0.2, -0.5])
        d = latlong_directions(32, 64)
        px = (1.0 + d @ a)[..., None].repeat(3, -1).astype(np.float32)
        got = turn_latlong(px, 37.0)
        want = 1.0 + d @ (turn_matrix(37.0) @ a)  # L(Rᵀd) = 1 + (Rᵀd)·a = 1 + d·(R a)
        np.testing.assert_allclose(got[..., 0], want, atol=2e-3)

    def test_full_turn_is_identity(self):
        px = np.random.default_rng(1).random((8, 16, 3)).astype(np.float32)
        assert np.array_equal(turn_latlong(px, 360.0), px)


class TestApplyPose:
    def test_records_and_turns(self, tmp_path):
        m = write_test_exr(tmp_path / "m.exr", np.ones((8, 16, 3)))
        env = load_environment(str(m), quiet=True)
        R = apply_pose(env, {"position": [1, 2, 3], "rotation_deg": 45.0})
        assert np.array_equal(env.meta["probe_position"], [1.0, 2.0, 3.0])
        assert env.meta["probe_rotation_deg"] == 45.0
        np.testing.assert_allclose(R, turn_matrix(45.0))
        assert apply_pose(env, {"position": [0, 0, 0], "rotation_deg": 45.0}, True) is None


POSE = {"position": [1.0, -2.0, 0.5], "rotation_deg": 90.0}
SETTINGS = {
    "env_sh": {"lmax": 4, "irradiance": True, "tangent": True, "extract_sun": True},
    "shrm": {"brdf": "microfacet", "params": {"sigma": 0.3}, "merl": None, "eps": 0.05,
             "F": 8, "P": 2, "face_size": 16},
    "splitsum": {"splitsum": {"top": 16, "min_size": 8, "alphas": [0.1, 0.5],
                              "samples": 64}},
    "shexp": {"fit": {"alpha_min": 0.25, "alpha_max": 0.81, "alpha_count": 2, "sets": 1,
                      "samples": 64, "normals": 64, "views": 16}},
}  # fmt: skip


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """The sunset map and its copy turned by 90° about +Y with numpy (columns rolled by W/4:
    column j shows the original's j + W/4)."""
    folder = tmp_path_factory.mktemp("pose")
    px, _ = read_image(str(map_path("sunset")))
    src = write_test_exr(folder / "sunset.exr", px)
    rolled = write_test_exr(folder / "rolled.exr", np.roll(px, -px.shape[1] // 4, axis=1))
    return folder, str(src), str(rolled)


def _bake(folder, kind, source, name, pose):
    settings = dict(SETTINGS[kind], pose=pose)
    asset = {"id": f"{kind}/{name}", "kind": kind, "inputs": [source], "settings": settings,
             "output": str(folder / kind / f"{name}.h5"), "plan_key": "", "tolerances": {},
             "predicted_error": {}, "predicted_seconds": 0.0}  # fmt: skip
    bake_asset(asset, measure=False)
    return read_asset(asset["output"])


class TestRotatedProbeEqualsRotatedMap:
    @pytest.mark.parametrize("kind, paths, atol", [
        ("env_sh", ("/lighting/sh", "/irradiance/sh", "/tangent_irradiance/sh",
                    "/sun/direction"), 1e-6),
        ("shrm", ("/shrm", "/lighting/sh"), 1e-5),
        ("splitsum", None, 0.0),
        ("shexp", ("/p", "/q"), 0.0),
    ])  # fmt: skip
    def test_same_asset(self, maps, kind, paths, atol):
        folder, src, rolled = maps
        turned = _bake(folder, kind, src, "turned", POSE)
        ref = _bake(folder, kind, rolled, "rolled", {"position": [0, 0, 0], "rotation_deg": 0})
        paths = paths or [p for p in ref.datasets if p.startswith("/levels")]
        assert paths
        for p in paths:
            a, b = np.asarray(turned[p], float), np.asarray(ref[p], float)
            np.testing.assert_allclose(a, b, atol=atol * max(1.0, np.abs(b).max()), err_msg=p)
        assert np.array_equal(turned.attrs["probe_position"], POSE["position"])
        assert turned.attrs["probe_rotation_deg"] == 90.0

    def test_export_cube_maps_follow_the_turn(self, maps, tmp_path):
        from shbake.batch.export import export_assets
        from tests.helpers import ktx2_levels

        folder, src, rolled = maps
        out = {}
        for name, source, pose in (("turned", src, POSE),
                                   ("rolled", rolled, {"position": [0, 0, 0],
                                                       "rotation_deg": 0})):  # fmt: skip
            _bake(folder, "env_sh", source, name, pose)
            files = export_assets([str(folder / "env_sh" / f"{name}.h5")], "ktx2",
                                  str(tmp_path / name), many=True, size=16, floor=4,
                                  samples=32)  # fmt: skip
            out[name] = ktx2_levels(next(f for f in files if f.endswith(f"{name}.ktx2")))
        for a, b in zip(out["turned"], out["rolled"], strict=True):
            np.testing.assert_allclose(a, b, rtol=2e-3, atol=1e-3 * np.abs(b).max())
