"""``shbake export`` (:mod:`shbake.batch.export`): every target written twice with identical
bytes, options a target does not read refused, bad targets, inputs and names refused in one
line before any cube chain is baked, split-sum probes to KTX2 (read by ktx-parse under node).

What each target writes, checked in the engines' own code: ``tests/format/exports/``.
"""

import json
import os
import shutil

import pytest

from tests.export_checks import SHARED
from tests.export_checks import read_ktx2 as _ktx2

pytestmark = pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")


class TestExportCommand:
    """``shbake export``: the CLI over export_assets, its errors and byte-identical output."""

    def test_every_target_writes_and_is_deterministic(self, run_cli, sky_asset, tmp_path):
        outs = {
            "gltf": "a.gltf",
            "babylon": "a.env",
            "threejs": "a.json",
            "threejs-pmrem": "a_pmrem.ktx2",
            "ktx2": "a.ktx2",
            "filament": "a_sh.txt",
            "unity": "a.unity.json",
        }
        for target, name in outs.items():
            small = ["--size", "8", "--floor", "2", "--samples", "16"]
            small = small if target not in ("threejs", "unity") else []
            first = {}
            for run in (1, 2):
                d = tmp_path / f"{target}{run}"
                d.mkdir()
                code, stdout, err = run_cli(
                    "export", sky_asset["h5"], "--to", target, "-o", d / name, *small, "--json"
                )
                assert code == 0, err
                written = json.loads(stdout)["written"]
                files = {os.path.basename(p): open(p, "rb").read() for p in written}
                if run == 1:
                    first = files
            assert files == first, target  # same inputs -> identical bytes

    @pytest.mark.parametrize(
        ("target", "args", "named"),
        [
            ("threejs", ["--size", "8"], "--size"),
            ("unity", ["--env", "x.exr", "--samples", "16"], "--env, --samples"),
            ("threejs", ["--sun-radius", "5"], "--sun-radius"),
            ("filament", ["--lod-mapping", "gltf-ibl-sampler"], "--lod-mapping"),
            ("threejs-pmrem", ["--lod-mapping", "filament"], "--lod-mapping"),
            ("ktx2", ["--babylon-scene", "right-handed"], "--babylon-scene"),
        ],
    )
    def test_option_the_target_does_not_read_is_refused(
        self, run_cli, sky_asset, tmp_path, target, args, named
    ):
        out = tmp_path / "x.out"
        code, _, err = run_cli("export", sky_asset["h5"], "--to", target, "-o", out, *args)
        lines = [x for x in err.splitlines() if x.startswith("shbake: error:")]
        assert code == 1 and len(lines) == 1 and named in lines[0] and target in lines[0], err
        assert os.listdir(tmp_path) == []

    def test_options_of_target(self):
        from shbake.batch.export import TARGET_OPTIONS, options_of_target
        from shbake.format.exports import TARGETS

        cube = {"env_path", "size", "floor", "samples", "sun_radius_deg"}
        assert options_of_target("threejs") == options_of_target("unity") == frozenset()
        assert options_of_target("filament") == options_of_target("threejs-pmrem") == cube
        assert options_of_target("ktx2") == cube | {"mapping"}
        assert options_of_target("gltf") == options_of_target("babylon") == set(TARGET_OPTIONS)
        assert all(options_of_target(t) <= set(TARGET_OPTIONS) for t in TARGETS)

    def test_errors(self, run_cli, sky_asset, tmp_path, monkeypatch):
        """Bad targets, inputs and output names get one line, before any cube chain is baked."""

        def no_bake(*args, **kwargs):
            raise AssertionError("a cube chain was baked for an export that is refused")

        monkeypatch.setattr("shbake.batch.export.prefilter_chain", no_bake)
        code, _, err = run_cli("export", sky_asset["h5"], "--to", "unreal", "-o", tmp_path / "x")
        assert code == 2 and "unreal" in err
        code, _, err = run_cli(
            "export",
            sky_asset["h5"],
            "--to",
            "gltf",
            "-o",
            tmp_path / "x.gltf",
            "--env",
            tmp_path / "missing.exr",
        )
        assert code == 1 and err.startswith("shbake: error:")
        for target, name, ending in [("gltf", "x.glb", ".gltf"), ("babylon", "x.babylon", ".env"),
                                     ("filament", "x.ktx", "_sh.txt"), ("ktx2", "x.ktx", ".ktx2"),
                                     ("threejs-pmrem", "x.exr", ".ktx2")]:  # fmt: skip
            code, _, err = run_cli("export", sky_asset["h5"], "--to", target, "-o", tmp_path / name)
            assert code == 1 and ending in err and err.count("\n") == 1, (target, err)
        assert os.listdir(tmp_path) == []

    @pytest.mark.parametrize(
        ("args", "named"),
        [
            (["--lod-mapping", "filament"], "--lod-mapping babylon"),
            (["--babylon-scene", "right-handed"], "--rotate 180"),
            (["--floor", "1", "--size", "1"], "--size"),
        ],
    )
    def test_babylon_env_refusals(self, run_cli, sky_asset, tmp_path, args, named):
        """What a .env cannot hold is refused with one line, nothing written."""
        out = tmp_path / "x.env"
        small = ["--size", "8", "--floor", "2", "--samples", "16"]
        code, _, err = run_cli("export", sky_asset["h5"], "--to", "babylon", "-o", out, *small,
                               *args)  # fmt: skip
        lines = [x for x in err.splitlines() if x.startswith("shbake: error:")]
        assert code == 1 and len(lines) == 1 and named in lines[0], err
        assert os.listdir(tmp_path) == []

    def test_splitsum_probe_to_ktx2(self, run_cli, tmp_path):
        """A split-sum probe exports its map's cube chain (--env, SHA-256 checked); not SH."""
        path = os.path.join(SHARED, "hdri", "forest.exr")
        probe = tmp_path / "p.h5"
        code, _, err = run_cli(
            "split-sum",
            path,
            "-o",
            probe,
            "--size",
            "16",
            "--min-size",
            "8",
            "--alphas",
            "0.25,1",
            "--samples",
            "16",
            "-q",
        )
        assert code == 0, err
        code, _, err = run_cli(
            "export",
            probe,
            "--to",
            "ktx2",
            "-o",
            tmp_path / "p.ktx2",
            "--env",
            path,
            "--size",
            "8",
            "--samples",
            "16",
        )
        assert code == 0, err
        r = _ktx2(str(tmp_path / "p.ktx2"))
        assert (r["faceCount"], r["levelCount"], r["pixelWidth"]) == (6, 4, 8)
        code, _, err = run_cli("export", probe, "--to", "threejs", "-o", tmp_path / "p.json")
        assert code == 1 and "env_sh" in err
        other = os.path.join(SHARED, "hdri", "city.exr")
        code, _, err = run_cli(
            "export", probe, "--to", "ktx2", "-o", tmp_path / "q.ktx2", "--env", other
        )
        assert code == 1 and "SHA-256" in err

    def test_out_dir_for_several_assets(self, run_cli, sky_asset, tmp_path):
        code, _, err = run_cli("export", sky_asset["h5"], sky_asset["h5"], "--to", "unity",
                               "-o", tmp_path / "x.unity.json")  # fmt: skip
        assert code == 2 and "--out-dir" in err
        code, _, err = run_cli(
            "export", sky_asset["h5"], "--to", "unity", "--out-dir", tmp_path / "u"
        )
        assert code == 0, err
        assert (tmp_path / "u" / "s.unity.json").exists()
