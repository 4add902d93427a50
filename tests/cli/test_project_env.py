"""``shbake project-env`` end to end, determinism, and every bad input of the issue."""

import json
import os

import h5py
import numpy as np
import pytest

from shbake.format.asset import read_asset
from tests.helpers import map_path, repeat_first_light, write_test_exr

ESPLANADE = map_path("esplanade")


class TestProjectEnv:
    def test_writes_asset_maps_gltf_and_json(self, run_cli, tmp_path):
        out = tmp_path / "sky.h5"
        code, stdout, err = run_cli(
            "project-env",
            ESPLANADE,
            "-o",
            out,
            "--lmax",
            "8",
            "--extract-sun",
            "--exr-dir",
            tmp_path / "maps",
            "--float-exr",
            "--export",
            "gltf",
            "--json",
            "--report",
        )
        assert code == 0, err
        summary = json.loads(stdout)
        assert summary["lmax"] == 8 and summary["sun"]["extracted"]
        a = read_asset(str(out))
        assert a.attrs["format"] == "shbake" and a.attrs["kind"] == "env_sh"
        assert a["/lighting/sh"].shape == (81, 3) and a["/irradiance/sh"].shape == (9, 3)
        assert a["/tangent_irradiance/matrix"].shape == (3, 4, 4)
        assert a.attrs["source_sha256"] and "project-env" in a.attrs["command_line"]
        assert a.attrs["source_negative_count"] > 0
        assert (tmp_path / "maps" / "irradiance.exr").exists()
        gltf = json.loads((tmp_path / "sky-gltf" / "sky.gltf").read_text())  # export --to gltf
        light = gltf["extensions"]["EXT_lights_image_based"]["lights"][0]
        signs = np.array([1, -1, 1, 1, -1, -1, 1, 1, 1])[:, None]  # Babylon (docs/EXPORTS.md)
        np.testing.assert_allclose(
            light["irradianceCoefficients"], signs * a["/irradiance/sh"] / light["intensity"] ** 2
        )
        assert "KHR_lights_punctual" in gltf["extensionsUsed"]
        assert "vs brute force" in err
        # what the settings cost, from the run's own figures (--json)
        assert (f"cost: baked in {summary['bake_seconds']:.3g} s; 81 lighting and 9 irradiance SH "
                "coefficients per channel") in err.splitlines()

    def test_same_inputs_give_identical_bytes(self, run_cli, tmp_path):
        args = [ESPLANADE, "--lmax", "4", "--extract-sun", "--window", "hann", "-q"]
        os.chdir(tmp_path)
        assert run_cli("project-env", *args, "-o", "a.h5")[0] == 0
        os.replace("a.h5", "b.h5")
        assert run_cli("project-env", *args, "-o", "a.h5")[0] == 0
        assert (tmp_path / "a.h5").read_bytes() == (tmp_path / "b.h5").read_bytes()

    def test_dering_window_is_recorded(self, run_cli, tmp_path):
        out = tmp_path / "d.h5"
        assert (
            run_cli("project-env", map_path("studio"), "-o", out, "--window", "dering", "-q")[0]
            == 0
        )
        a = read_asset(str(out))
        assert a.dataset_attrs["/lighting/window"]["reconstruction_minimum"] >= 0

    @pytest.mark.parametrize("layout", ["cube-strip", "cross-h", "cross-v"])
    def test_cube_layouts_detected(self, run_cli, tmp_path, layout):
        shape = {"cube-strip": (48, 8), "cross-h": (24, 32), "cross-v": (32, 24)}[layout]
        src = write_test_exr(tmp_path / "c.exr", np.ones(shape + (3,)))
        code, stdout, err = run_cli("project-env", src, "-o", tmp_path / "c.h5", "--json")
        assert code == 0, err
        assert json.loads(stdout)["layout"] == layout
        assert read_asset(str(tmp_path / "c.h5"))["/lighting/sh"][0, 0] == pytest.approx(
            np.sqrt(4 * np.pi), rel=1e-9
        )

    def test_single_channel_and_rgba(self, run_cli, tmp_path):
        for c in (1, 4):
            src = write_test_exr(tmp_path / f"m{c}.exr", np.full((16, 32, c), 2.0))
            assert run_cli("project-env", src, "-o", tmp_path / f"m{c}.h5", "-q")[0] == 0
            L = read_asset(str(tmp_path / f"m{c}.h5"))["/lighting/sh"]
            np.testing.assert_allclose(L[0], 2 * np.sqrt(4 * np.pi), rtol=1e-9)

    def test_colorspace_conversion(self, run_cli, tmp_path):
        src = write_test_exr(tmp_path / "g.exr", np.tile([0.0, 1.0, 0.0], (16, 32, 1)))
        assert (
            run_cli(
                "project-env",
                src,
                "-o",
                tmp_path / "g.h5",
                "--colorspace",
                "ACEScg",
                "--negative",
                "keep",
                "-q",
            )[0]
            == 0
        )
        L = read_asset(str(tmp_path / "g.h5"))["/lighting/sh"][0] / np.sqrt(4 * np.pi)
        # ACEScg green lies outside Rec.709: red goes negative, green above 1.
        assert L[0] < 0 and L[1] > 1

    def test_fix_nonfinite(self, run_cli, tmp_path):
        img = np.ones((16, 32, 3))
        img[3, 4] = np.nan
        img[5, 6, 1] = np.inf
        src = write_test_exr(tmp_path / "n.exr", img)
        for fix in ("black", "box3"):
            out = tmp_path / f"n-{fix}.h5"
            assert run_cli("project-env", src, "-o", out, "--fix-nonfinite", fix, "-q")[0] == 0
            a = read_asset(str(out))
            assert a.attrs["source_nonfinite_repaired"] == 2
        # box3 restores the constant map exactly.
        L = read_asset(str(tmp_path / "n-box3.h5"))["/lighting/sh"]
        np.testing.assert_allclose(L[0], np.sqrt(4 * np.pi), rtol=1e-12)


def one_line_error(code, err):
    lines = [l for l in err.strip().splitlines() if l.strip()]
    return code != 0 and len(lines) == 1 and lines[0].startswith("shbake: error:")


class TestBadInput:
    @pytest.fixture
    def nan_map(self, tmp_path):
        img = np.ones((16, 32, 3))
        img[2, 2] = np.nan
        return write_test_exr(tmp_path / "nan.exr", img)

    def case(self, run_cli, tmp_path, *args):
        out = tmp_path / "out.h5"
        before = set(tmp_path.rglob("*"))
        code, _, err = run_cli("project-env", *args, "-o", out)
        assert one_line_error(code, err), err
        assert set(tmp_path.rglob("*")) == before  # no output, no temp file left
        return err

    def test_nan_pixels(self, run_cli, tmp_path, nan_map):
        assert "NaN" in self.case(run_cli, tmp_path, nan_map)

    def test_negative_error_policy(self, run_cli, tmp_path):
        assert "negative" in self.case(run_cli, tmp_path, ESPLANADE, "--negative", "error")

    def test_unknown_aspect(self, run_cli, tmp_path):
        src = write_test_exr(tmp_path / "odd.exr", np.ones((10, 17, 3)))
        assert "layout" in self.case(run_cli, tmp_path, src)

    def test_layout_override_that_does_not_fit(self, run_cli, tmp_path):
        assert "layout" in self.case(run_cli, tmp_path, ESPLANADE, "--layout", "cube-strip")

    def test_unknown_layout_name(self, run_cli, tmp_path):
        self.case(run_cli, tmp_path, ESPLANADE, "--layout", "octahedral")

    def test_truncated_file(self, run_cli, tmp_path):
        src = tmp_path / "trunc.exr"
        src.write_bytes(ESPLANADE.read_bytes()[:100_000])
        assert "truncated" in self.case(run_cli, tmp_path, src)

    def test_corrupt_file(self, run_cli, tmp_path):
        data = bytearray(ESPLANADE.read_bytes())
        data[400:20000] = bytes(19600)
        src = tmp_path / "corrupt.exr"
        src.write_bytes(bytes(data))
        self.case(run_cli, tmp_path, src)

    def test_empty_file(self, run_cli, tmp_path):
        src = tmp_path / "empty.exr"
        src.write_bytes(b"")
        assert "empty" in self.case(run_cli, tmp_path, src)

    def test_non_image_file(self, run_cli, tmp_path):
        src = tmp_path / "notes.exr"
        src.write_text("not an image\n")
        assert "not a readable image" in self.case(run_cli, tmp_path, src)

    def test_missing_file(self, run_cli, tmp_path):
        assert "no such file" in self.case(run_cli, tmp_path, tmp_path / "missing.exr")

    @pytest.mark.parametrize("lmax", ["-1", "129", "abc"])
    def test_absurd_lmax(self, run_cli, tmp_path, lmax):
        self.case(run_cli, tmp_path, ESPLANADE, "--lmax", lmax)

    def test_half_overflow_on_exr_write(self, run_cli, tmp_path):
        img = np.ones((32, 64, 3))
        img[10, 10] = 1e9  # a 1-pixel light: its irradiance overflows half floats
        src = write_test_exr(tmp_path / "hot.exr", img)
        err = self.case(run_cli, tmp_path, src, "--exr-dir", tmp_path / "maps")
        assert "half" in err and not (tmp_path / "maps").exists()

    def test_unwritable_output(self, run_cli, tmp_path):
        code, _, err = run_cli("project-env", ESPLANADE, "-o", tmp_path / "nodir" / "x.h5")
        assert one_line_error(code, err)
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        try:
            if os.access(ro, os.W_OK):  # root ignores permissions: use a path under a file
                target = tmp_path / "afile"
                target.write_text("x")
                code, _, err = run_cli("project-env", ESPLANADE, "-o", target / "x.h5")
            else:
                code, _, err = run_cli("project-env", ESPLANADE, "-o", ro / "x.h5")
            assert one_line_error(code, err)
        finally:
            ro.chmod(0o700)

    def test_existing_output_survives_a_failed_run(self, run_cli, tmp_path, nan_map):
        out = tmp_path / "keep.h5"
        out.write_bytes(b"previous")
        code, _, _ = run_cli("project-env", nan_map, "-o", out)
        assert code != 0 and out.read_bytes() == b"previous"


class TestAssetReader:
    def test_refuses_unknown_kind_version_and_non_assets(self, run_cli, tmp_path):
        out = tmp_path / "a.h5"
        assert run_cli("project-env", ESPLANADE, "-o", out, "-q")[0] == 0
        for attr, value, word in (
            ("kind", "mystery", "kind"),
            ("format_version", 99, "version"),
            ("format", "other", "not a shbake asset"),
        ):
            bad = tmp_path / f"bad-{attr}.h5"
            bad.write_bytes(out.read_bytes())
            with h5py.File(bad, "r+") as f:
                f.attrs[attr] = value
            code, _, err = run_cli("preview", bad, "-o", tmp_path / "p.exr")
            assert one_line_error(code, err) and word in err
        trunc = tmp_path / "trunc.h5"
        trunc.write_bytes(out.read_bytes()[:2000])
        code, _, err = run_cli("preview", trunc, "-o", tmp_path / "p.exr")
        assert one_line_error(code, err)
        assert not (tmp_path / "p.exr").exists()


class TestLightShape:
    """``--light-shape sphere``: what takes it, what refuses it (one line, nothing written)."""

    @pytest.fixture(scope="class")
    @classmethod
    def disc_map(cls, tmp_path_factory):
        """A grey sky with a disc of 10° (radiance 500) at 30° elevation."""
        from shbake.envmap.layouts import latlong_directions

        d = latlong_directions(48, 96)
        s = np.array([0.0, 0.5, -np.sqrt(0.75)])
        img = np.where(((d @ s) > np.cos(np.radians(10.0)))[..., None], 500.0, 0.5)
        return write_test_exr(tmp_path_factory.mktemp("disc") / "disc.exr", img * np.ones(3))

    @pytest.fixture(scope="class")
    @classmethod
    def sphere_asset(cls, disc_map, tmp_path_factory):
        from click.testing import CliRunner
        from shbake_cli.main import cli

        out = tmp_path_factory.mktemp("sphere") / "disc.h5"
        r = CliRunner().invoke(cli, ["project-env", str(disc_map), "-o", str(out), "--lights",
                                     "1", "--light-shape", "sphere", "-q"])  # fmt: skip
        assert r.exit_code == 0, r.output
        return out

    @pytest.mark.parametrize("args, fragment", [
        (["--light-shape", "sphere"], "--lights only"),
        (["--lights", "1", "--light-shape", "sphere", "--export", "threejs"], "points"),
        (["--lights", "1", "--light-shape", "cap"], "cap"),
    ])  # fmt: skip
    def test_refused(self, run_cli, tmp_path, disc_map, args, fragment):
        before = set(tmp_path.rglob("*"))
        code, _, err = run_cli("project-env", disc_map, "-o", tmp_path / "out.h5", *args)
        assert one_line_error(code, err) and fragment in err, err
        assert set(tmp_path.rglob("*")) == before

    def test_json_and_asset(self, run_cli, tmp_path, disc_map):
        code, out, err = run_cli("project-env", disc_map, "-o", tmp_path / "a.h5", "--lights", "1",
                                 "--light-shape", "sphere", "--json", "-q")  # fmt: skip
        assert code == 0, err
        lights = json.loads(out)["lights"]
        assert lights["shape"] == "sphere"
        radius = lights["lights"][0]["angular_radius_deg"]
        assert radius == pytest.approx(10.0, abs=1.0)  # texels of 3.75°
        got = read_asset(str(tmp_path / "a.h5"))["/lights/angular_radius"]
        assert np.degrees(got[0]) == pytest.approx(radius, rel=1e-12)

    @pytest.mark.parametrize("target, name", [("threejs", "x"), ("gltf", "x.gltf"),
                                              ("babylon", "x.gltf"), ("filament", "x_sh.txt"),
                                              ("unity", "x")])  # fmt: skip
    def test_engine_exports_refuse_the_asset(self, run_cli, tmp_path, sphere_asset, target, name):
        code, _, err = run_cli("export", sphere_asset, "--to", target, "-o", tmp_path / name)
        assert one_line_error(code, err) and "spheres" in err, err
        assert not any(tmp_path.iterdir())

    def test_webgl_export_refuses_more_lights_than_its_shader_holds(self, run_cli, tmp_path,
                                                                     sphere_asset):  # fmt: skip
        """Nine lights (a valid asset: the format has no limit; three.js takes them)."""
        path = tmp_path / "nine.h5"
        repeat_first_light(sphere_asset, path, 9)
        read_asset(str(path))
        code, _, err = run_cli("export", path, "--to", "webgl", "-o", tmp_path / "w")
        assert one_line_error(code, err) and "at most 8 lights" in err, err
        assert not (tmp_path / "w").exists()

    def test_webgl_export_carries_the_radii(self, run_cli, tmp_path, sphere_asset):
        code, _, err = run_cli("export", sphere_asset, "--to", "webgl", "-o", tmp_path / "w")
        assert code == 0, err
        manifest = json.loads((tmp_path / "w" / "shbake.json").read_text())
        radii = manifest["uniforms"]["uLightRadius"]["value"]
        want = read_asset(str(sphere_asset))["/lights/angular_radius"]
        np.testing.assert_allclose(radii[:1], want, rtol=1e-6)
        assert radii[1:] == [0.0] * (len(radii) - 1)
