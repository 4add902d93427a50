"""Preview passes: analytic dome values, agreement with brute force, outputs."""

import json

import numpy as np
import pytest

from shbake.format.asset import read_asset
from shbake.preview.passes import render_pass
from shbake.preview.sphere import sphere_geometry
from shbake.shading.shader import shader
from tests.helpers import map_path, write_test_exr


@pytest.fixture
def dome_asset(run_cli, tmp_path):
    src = write_test_exr(tmp_path / "dome.exr", np.ones((32, 64, 3)))
    assert run_cli("project-env", src, "-o", tmp_path / "dome.h5", "-q")[0] == 0
    return tmp_path / "dome.h5"


class TestPasses:
    def test_white_dome_shades_to_albedo(self, dome_asset):
        a = read_asset(str(dome_asset))
        _, _, mask = sphere_geometry(32)
        img, _ = render_pass(shader(a, "irradiance"), 32)
        np.testing.assert_allclose(img[mask], 1.0, rtol=1e-9)  # Lambert ρ=1 → radiance 1
        img, _ = render_pass(shader(a, "tangent"), 32)
        np.testing.assert_allclose(img[mask], 1.0, rtol=1e-9)
        assert np.all(img[~mask] == 0)

    def test_tangents_follow_longitude_lines(self):
        n, t, mask = sphere_geometry(16)
        assert np.abs(np.sum(n * t, axis=-1)[mask]).max() < 1e-12
        assert np.all(t[mask][:, 1] >= 0)  # pointing toward +Y


class TestPreviewCli:
    def test_diff_against_brute_force(self, run_cli, tmp_path):
        asset = tmp_path / "e.h5"
        assert (
            run_cli(
                "project-env",
                map_path("city"),
                "-o",
                asset,
                "--lmax",
                "8",
                "--irradiance-lmax",
                "8",
                "-q",
            )[0]
            == 0
        )
        code, out, err = run_cli(
            "preview",
            asset,
            "--pass",
            "irradiance",
            "-o",
            tmp_path / "p.exr",
            "--size",
            "48",
            "--diff",
            "--json",
        )
        assert code == 0, err
        s = json.loads(out)
        # city at lmax 8: mean error 0.1 % over the sphere (docs/BENCHMARKS.md).
        assert s["relative_rms_error"] < 0.01
        for name in ("p.exr", "p-sheet.png", "p-reference.exr", "p-diff.exr"):
            assert (tmp_path / name).exists()

    def test_reference_pass_needs_the_original(self, run_cli, tmp_path, dome_asset):
        (tmp_path / "dome.exr").unlink()
        code, _, err = run_cli(
            "preview", dome_asset, "--pass", "reference", "-o", tmp_path / "r.exr"
        )
        assert code != 0 and "not found" in err and not (tmp_path / "r.exr").exists()


class TestOptionsOfKind:
    """An option the asset's kind does not read is refused (one line, exit 1, no file)."""

    @pytest.mark.parametrize(
        ("kind", "args", "named"),
        [
            ("env_sh", ["--roughness", "0.3"], "--roughness"),
            ("env_sh", ["--alpha", "0.09", "--f0", "0.5"], "--alpha, --f0"),
            ("shexp_probe", ["--index", "3"], "--index"),
            ("splitsum_probe", ["--table", "t.h5"], "--table"),
            ("shrm", ["--samples", "64"], "--samples"),
        ],
    )
    def test_refused(self, run_cli, tmp_path, kind, args, named):
        from shbake.format.asset import write_asset
        from tests.assets_examples import example, write_map

        asset = tmp_path / "a.h5"
        write_asset(str(asset), example(kind, write_map(tmp_path / "m.exr")))
        code, _, err = run_cli("preview", asset, "-o", tmp_path / "p.exr", "--size", "8", *args)
        lines = [x for x in err.splitlines() if x.startswith("shbake: error:")]
        assert code == 1 and len(lines) == 1 and named in lines[0], err
        assert kind in lines[0]
        assert not (tmp_path / "p.exr").exists()

    def test_read_options_still_pass(self, run_cli, tmp_path):
        from shbake.format.asset import write_asset
        from tests.assets_examples import example, write_map

        asset = tmp_path / "s.h5"
        write_asset(str(asset), example("shexp_probe_set", write_map(tmp_path / "m.exr")))
        args = ["--index", "1", "--roughness", "0.6", "--f0", "0.04", "-q"]
        code, _, err = run_cli("preview", asset, "-o", tmp_path / "p.exr", "--size", "8", *args)
        assert code == 0, err
