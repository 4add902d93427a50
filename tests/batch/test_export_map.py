"""``shbake export MAP --to TARGET -o OUT``: one step from map to engine (issue 32, Deliver 6).

The map is baked as ``project-env MAP --extract-sun`` would (lmax 2) and exported as
``export ASSET`` would: the oracle is those two commands run one after the other (the
exported bytes must be the same), an independent KTX2 header read for the filed failure
(``export sky.exr --to ktx2`` said "file signature not found"), and the folder listing:
no asset and no temporary is left unless ``--keep-asset`` asks for it.
"""

import json
import os

import h5py
import numpy as np
import pytest

from tests.faults import assert_failed, unchanged
from tests.helpers import map_path, repeat_first_light, write_test_exr

KTX2_IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"
"""KTX 2.0 §3.1: the file's first 12 bytes."""


@pytest.fixture(scope="module")
def sky(tmp_path_factory):
    """A small map with a sun: 32×64 sky, one bright 2×2 patch."""
    folder = tmp_path_factory.mktemp("sky")
    img = np.full((32, 64, 3), 0.5)
    img[8:10, 20:22] = 2000.0
    return str(write_test_exr(folder / "sky.exr", img))


def listing(folder) -> list[str]:
    return sorted(os.listdir(folder))


def contents(folder) -> dict[str, bytes]:
    """``name → bytes`` of the files in ``folder``."""
    return {name: (folder / name).read_bytes() for name in listing(folder)}


class TestOneStep:
    def test_same_bytes_as_two_commands(self, tmp_path, run_cli, sky):
        one, two = tmp_path / "one", tmp_path / "two"
        one.mkdir()
        two.mkdir()
        code, _, err = run_cli("export", sky, "--to", "threejs", "-o", one / "sky.json")
        assert code == 0, err
        assert listing(one) == ["sky.json"]  # no asset, no temporary
        assert "sky.exr: baked env_sh lmax 2 (the sun extracted, window none); error " in err
        assert run_cli("project-env", sky, "-o", two / "sky.h5", "--extract-sun", "-q")[0] == 0
        assert run_cli("export", two / "sky.h5", "--to", "threejs", "-o", two / "sky.json")[0] == 0
        assert (one / "sky.json").read_bytes() == (two / "sky.json").read_bytes()

    def test_filed_ktx2_case(self, tmp_path, run_cli, sky):
        """Issue 32 item 6: ``export sky.exr --to ktx2`` failed with "file signature not
        found" (the map was read as an HDF5 asset)."""
        code, _, err = run_cli("export", sky, "--to", "ktx2", "-o", tmp_path / "sky.ktx2",
                               "--size", "16", "--samples", "16")  # fmt: skip
        assert code == 0, err
        assert listing(tmp_path) == ["sky.ktx2", "sky_dfg.exr", "sky_dfg.ktx2"]
        assert (tmp_path / "sky.ktx2").read_bytes()[:12] == KTX2_IDENTIFIER

    def test_keep_asset_and_json(self, tmp_path, run_cli, sky):
        code, out, err = run_cli("export", sky, "--to", "threejs", "-o", tmp_path / "s.json",
                                 "--keep-asset", tmp_path / "s.h5", "--lmax", "3",
                                 "--no-extract-sun", "--json", "-q")  # fmt: skip
        assert code == 0 and err == "", err
        summary = json.loads(out)
        assert listing(tmp_path) == ["s.h5", "s.json"]
        assert summary["written"] == [str(tmp_path / "s.h5"), str(tmp_path / "s.json")]
        (bake,) = summary["bakes"]
        assert bake["lmax"] == 3 and not bake.get("sun", {}).get("extracted")
        with h5py.File(tmp_path / "s.h5", "r") as f:
            assert f["lighting/sh"].shape == (16, 3) and "sun" not in f

    def test_several_maps_out_dir(self, tmp_path, run_cli):
        maps = [map_path("studio"), map_path("night")]
        code, _, err = run_cli("export", *maps, "--to", "threejs", "--out-dir", tmp_path / "o",
                               "-q")  # fmt: skip
        assert code == 0, err
        assert listing(tmp_path / "o") == ["night.json", "studio.json"]

    def test_several_maps_each_chain_from_its_map(self, tmp_path, run_cli, sky):
        """A target with cube maps bakes each map input's chain from that map: the second map's
        export was refused ("its SHA-256 differs"), the first map's path having become the
        ``--env`` of every later input. Each file is the bytes of the map's export alone."""
        other = str(write_test_exr(tmp_path / "other.exr", np.full((32, 64, 3), 0.25)))
        small = ["--size", "16", "--floor", "4", "--samples", "16", "-q"]
        code, _, err = run_cli("export", sky, other, "--to", "threejs-pmrem", "--out-dir",
                               tmp_path / "o", *small)  # fmt: skip
        assert code == 0, err
        assert listing(tmp_path / "o") == ["other_pmrem.ktx2", "sky_pmrem.ktx2"]
        for name, path in (("sky", sky), ("other", other)):
            alone = tmp_path / f"{name}.ktx2"
            assert run_cli("export", path, "--to", "threejs-pmrem", "-o", alone, *small)[0] == 0
            assert (tmp_path / "o" / f"{name}_pmrem.ktx2").read_bytes() == alone.read_bytes()


class TestRefused:
    @pytest.mark.parametrize("content", [b"not an image at all", b"\x89HDF\r\n\x1a\ngarbage"])
    def test_hostile_input_one_line(self, tmp_path, run_cli, content):
        bad = tmp_path / "in" / "sky.exr"
        bad.parent.mkdir()
        bad.write_bytes(content)
        out = tmp_path / "out"
        out.mkdir()
        (out / "sky.json").write_text("old")
        code, stdout, err = run_cli("export", bad, "--to", "threejs", "-o", out / "sky.json")
        assert code == 1 and stdout == "" and err.count("\n") == 1, err
        assert err.startswith("shbake: error: ") and str(bad) in err
        assert listing(out) == ["sky.json"] and (out / "sky.json").read_text() == "old"

    def test_map_options_need_a_map(self, tmp_path, run_cli, sky):
        asset = tmp_path / "a.h5"
        assert run_cli("project-env", sky, "-o", asset, "-q")[0] == 0
        code, _, err = run_cli("export", asset, "--to", "threejs", "-o", tmp_path / "a.json",
                               "--lmax", "4")  # fmt: skip
        assert code == 1
        assert err == "shbake: error: --lmax: read for an environment-map input only\n"
        assert listing(tmp_path) == ["a.h5"]

    def test_failed_export_leaves_no_asset(self, tmp_path, run_cli, sky):
        """The bake succeeds, the export fails (webgl refuses --rotate): nothing is left."""
        code, _, err = run_cli("export", sky, "--to", "webgl", "-o", tmp_path / "w",
                               "--rotate", "30", "--keep-asset", tmp_path / "k.h5")  # fmt: skip
        assert code == 1 and err.count("\n") == 1, err
        assert listing(tmp_path) == []


class TestGlossyReport:
    """``export --report`` to a target with cube maps: each input's chain as its engine reads
    it (:mod:`shbake.evaluation.cube_chain`), on stderr and in ``--json``; none without."""

    def test_chain_line_and_json(self, tmp_path, run_cli, sky):
        code, out, err = run_cli("export", sky, "--to", "threejs-pmrem", "-o",
                                 tmp_path / "s.ktx2", "--size", "32", "--floor", "4",
                                 "--samples", "64", "--report", "--json")  # fmt: skip
        assert code == 0, err
        (chain,) = json.loads(out)["glossy"]
        assert (chain["input"], chain["size"], chain["floor"], chain["levels"]) == (sky, 32, 4, 4)
        assert chain["mapping"] == "filament" and chain["bake_s"] > 0
        rows = chain["roughness"]
        assert [e["roughness"] for e in rows] == [0.1, 0.3, 0.6]
        # three.js's roughnessToMip: ENVMAP_MAX_LOD * r * (2 - r), ENVMAP_MAX_LOD = levels - 1
        assert [e["lod"] for e in rows] == pytest.approx([3 * r * (2 - r) for r in (0.1, 0.3, 0.6)])
        assert all(0 <= e["median"] <= e["p95"] for e in rows)
        assert f"{sky}: glossy chain 32² to 4² (4 levels, 64 samples, baked in " in err
        assert ("the glossy chain as the engine reads it" in err) == bool(chain["warnings"])

    def test_no_chain_no_glossy_report(self, tmp_path, run_cli, sky):
        code, out, err = run_cli("export", sky, "--to", "threejs", "-o", tmp_path / "s.json",
                                 "--report", "--json", "-q")  # fmt: skip
        assert code == 0, err
        assert json.loads(out)["glossy"] == []


@pytest.fixture(scope="module")
def assets(tmp_path_factory, sky):
    """``(good, spheres)``: the sky baked plainly, and a sky with a 10° disc (radiance
    500) baked with one sphere light (its radius fitted near 10°)."""
    from shbake.bakers.env_sh import bake_env_sh
    from shbake.envmap import load_environment
    from shbake.envmap.layouts import latlong_directions
    from shbake.format.asset import read_asset, write_asset

    folder = tmp_path_factory.mktemp("batch")
    d = latlong_directions(32, 64)
    s = np.array([0.0, 0.5, -np.sqrt(0.75)])
    disc = np.where(((d @ s) > np.cos(np.radians(10.0)))[..., None], 500.0, 0.5)
    disc_map = write_test_exr(folder / "disc.exr", disc * np.ones(3))
    good, spheres = str(folder / "good.h5"), str(folder / "spheres.h5")
    write_asset(good, bake_env_sh(load_environment(sky, quiet=True))[0])
    write_asset(spheres, bake_env_sh(load_environment(str(disc_map), quiet=True), lights=1,
                                     light_shape="sphere")[0])  # fmt: skip
    assert read_asset(spheres)["/lights/angular_radius"][0] > np.radians(5.0)
    return good, spheres


def watch(monkeypatch, *steps) -> list:
    """Record each call of the functions ``steps`` (``(module, name)``) by name in the list
    returned; each still runs."""
    calls = []

    def recorded(owner, name):
        original = getattr(owner, name)

        def call(*args, **kwargs):
            calls.append(name)
            return original(*args, **kwargs)

        monkeypatch.setattr(owner, name, call)

    for owner, name in steps:
        recorded(owner, name)
    return calls


class TestBatchCheckedFirst:
    """``export GOOD.h5 MAP SPHERES.h5 --to ENGINE --out-dir D``: the engines shade lights as
    points and refuse an asset with sphere lights (``/lights/angular_radius`` > 0). Every asset
    of the batch is checked before any export work: the one-line refusal comes before the
    good asset is exported or the map baked (it came after both), and the old outputs stay as
    they were, no temporary beside them."""

    @staticmethod
    def watch(monkeypatch, target) -> list:
        """Record every export step (the map's bake, a cube chain, the target's writer) in the
        list returned; each still runs."""
        from shbake.batch import export, export_map
        from shbake.format.exports import target_module

        return watch(monkeypatch, (export_map, "project_environment"),
                     (export, "prefilter_chain"), (target_module(target), "write"))  # fmt: skip

    @pytest.mark.parametrize("target", ["threejs", "gltf", "babylon", "filament", "unity"])
    def test_refused_before_any_work(self, tmp_path, run_cli, monkeypatch, sky, assets, target):
        from shbake.format.exports import target_module

        good, spheres = assets
        out = tmp_path / "out"
        out.mkdir()
        ext = target_module(target).EXTENSION
        for name in ("good", "sky", "spheres"):
            (out / f"{name}{ext}").write_text(f"old {name}")
        calls = self.watch(monkeypatch, target)
        small = ["--size", "8", "--floor", "2", "--samples", "16"]
        small = small if target_module(target).CUBES is not None else []
        with unchanged(tmp_path):
            result = run_cli("export", good, sky, spheres, "--to", target, "--out-dir", out,
                             *small)  # fmt: skip
        line = assert_failed(result, 1, "its lights are spheres")
        assert spheres in line
        assert calls == []

    def test_library_batch_refused_before_any_work(self, tmp_path, monkeypatch, assets):
        """:func:`shbake.batch.export.export_assets` outside a command's transaction (each
        file committed on its own): the good asset's export was left behind."""
        from shbake.batch.export import export_assets
        from shbake.errors import InputError

        out = tmp_path / "out"
        calls = self.watch(monkeypatch, "threejs")
        with unchanged(tmp_path), pytest.raises(InputError, match="spheres"):
            export_assets(list(assets), "threejs", str(out))
        assert calls == []


class TestWebglBatch:
    """``export ENV.h5 TABLE.h5 --to webgl --out-dir D --env ENV.h5``: ``--env`` lights the
    ``brdf_table`` assets of the batch (a table needs it; it needs a table), so the batch is
    read as one. It was refused ("--env is read for brdf_table assets only"): each input was
    exported on its own, ENV.h5 seen without the table. The webgl checks of every asset (at
    most 8 lights; sphere lights drawn) still come before any file is written or map baked."""

    @pytest.fixture(scope="class")
    @classmethod
    def batch(cls, tmp_path_factory, sky, assets):
        """``assets``, a Phong table (:mod:`tests.assets_examples`) and ``nine``: the sphere-light
        asset with its light repeated nine times (a valid asset; the shader holds 8)."""

        from shbake.format.asset import read_asset, write_asset
        from tests.assets_examples import example

        good, spheres = assets
        folder = tmp_path_factory.mktemp("webgl")
        table, nine = str(folder / "table.h5"), str(folder / "nine.h5")
        write_asset(table, example("brdf_table", sky))
        repeat_first_light(spheres, nine, 9)
        read_asset(nine)
        return {"good": good, "spheres": spheres, "table": table, "nine": nine}

    @staticmethod
    def watch(monkeypatch) -> list:
        """Record the map's bake and each webgl folder written; each still runs."""
        from shbake.batch import export_map
        from shbake.format.exports import webgl

        return watch(monkeypatch, (export_map, "project_environment"),
                     (webgl, "write_export"))  # fmt: skip

    @pytest.mark.parametrize("light", ["good", "spheres", "map"])
    def test_env_and_table_in_one_batch(self, tmp_path, run_cli, sky, batch, light):
        """Each folder of the batch is the bytes of its asset's export alone; the ``env_sh``
        input is the sky with its sun, the asset with a sphere light (drawn by webgl) or a map
        baked on the way (which does not read ``--env``)."""
        first = sky if light == "map" else batch[light]
        env = batch["good" if light == "map" else light]
        code, _, err = run_cli("export", first, batch["table"], "--to", "webgl", "--out-dir",
                               tmp_path / "d", "--env", env, "-q")  # fmt: skip
        assert code == 0, err
        stem = os.path.splitext(os.path.basename(first))[0]
        assert listing(tmp_path / "d") == sorted([stem, "table"])
        alone = {stem: [first], "table": [batch["table"], "--env", env]}
        for name, args in alone.items():
            assert run_cli("export", *args, "--to", "webgl", "-o", tmp_path / name, "-q")[0] == 0
            assert contents(tmp_path / "d" / name) == contents(tmp_path / name)
        manifest = json.loads((tmp_path / "d" / stem / "shbake.json").read_text())
        assert manifest["asset"]["kind"] == "env_sh"
        radius = manifest["uniforms"]["uLightRadius"]["value"][0]
        assert (radius > np.radians(5.0)) == (light == "spheres")

    def test_refused_before_any_write(self, tmp_path, run_cli, monkeypatch, sky, batch):
        """Nine lights in the last asset: one line naming it, before the good asset or the
        table is written or the map baked; the earlier exports in ``D`` byte-identical, no
        temporary."""
        out = tmp_path / "d"
        args = ("--to", "webgl", "--out-dir", out, "--env", batch["good"])
        assert run_cli("export", batch["good"], batch["table"], *args, "-q")[0] == 0
        calls = self.watch(monkeypatch)
        with unchanged(tmp_path):
            result = run_cli("export", batch["good"], batch["table"], sky, batch["nine"], *args)
        line = assert_failed(result, 1, "at most 8 lights")
        assert "nine.h5: " in line
        assert calls == []

    def test_library_batch_refused_before_any_write(self, tmp_path, monkeypatch, batch):
        """:func:`shbake.batch.export.export_assets` outside a command's transaction: the
        folders of the assets before the refused one were committed."""
        from shbake.batch.export import export_assets
        from shbake.errors import InputError

        calls = self.watch(monkeypatch)
        with unchanged(tmp_path), pytest.raises(InputError, match="at most 8 lights"):
            export_assets([batch["good"], batch["table"], batch["nine"]], "webgl",
                          str(tmp_path / "d"), env_path=batch["good"])  # fmt: skip
        assert calls == []

    def test_env_without_a_table_refused_before_the_bake(self, tmp_path, run_cli, monkeypatch,
                                                         sky, batch):  # fmt: skip
        """A map is baked into an ``env_sh`` asset, never a table: ``--env`` with maps alone is
        refused before the map is baked (it was refused after)."""
        calls = self.watch(monkeypatch)
        with unchanged(tmp_path):
            result = run_cli("export", sky, "--to", "webgl", "--out-dir", tmp_path / "d",
                             "--env", batch["good"])  # fmt: skip
        assert_failed(result, 1, "--env is read for brdf_table assets only")
        assert calls == []


class TestWebglReport:
    """``export … --to webgl --report``: each asset input measured by its kind. It failed in
    one line for any table (read as an ``env_sh`` asset) and for an ``env_sh`` asset beside
    one (measured against the ``--env`` asset, taken for its source map)."""

    @pytest.fixture(scope="class")
    @classmethod
    def inputs(cls, tmp_path_factory, sky):
        """The sky baked at lmax 4 with its whole irradiance SH (``--irradiance-lmax 4``, its
        ``project-env --report`` summary beside it), a Phong table baked as ``brdf-table``
        bakes it (its summary), a table of a constant MERL BRDF and an SH-exp probe
        (:mod:`tests.assets_examples`)."""
        from shbake.batch.brdf_table import bake_brdf_table
        from shbake.batch.project_env import project_environment
        from shbake.format.asset import write_asset
        from tests.assets_examples import example
        from tests.helpers import write_merl

        folder = tmp_path_factory.mktemp("webgl-report")
        env, table, merl, probe = (str(folder / n) for n in ("env.h5", "table.h5", "merl.h5",
                                                             "probe.h5"))  # fmt: skip
        write_asset(probe, example("shexp_probe", sky))
        write_merl(folder / "flat.binary", np.full((3, 90, 90, 180), 0.1))
        bake_brdf_table("merl", merl, merl_path=str(folder / "flat.binary"), lmax=2, size=(4, 4),
                        samples=64)  # fmt: skip
        return {
            "env": env, "table": table, "merl": merl, "probe": probe, "sky": sky,
            "env_summary": project_environment(sky, env, lmax=4, irradiance_lmax=4,
                                               report=True, quiet=True),
            "table_summary": bake_brdf_table("phong", table, {"n": "8"}, lmax=2, size=(8, 8),
                                             samples=64),
        }  # fmt: skip

    def test_table_alone(self, tmp_path, run_cli, inputs):
        """The filed case: a table alone, lit by ``--env``; its error is the one
        ``brdf-table`` printed when it wrote it."""
        code, out, err = run_cli("export", inputs["table"], "--to", "webgl", "-o", tmp_path / "d",
                                 "--env", inputs["env"], "--report", "--json")  # fmt: skip
        assert code == 0, err
        (m,) = json.loads(out)["measured"]
        assert (m["input"], m["kind"]) == (inputs["table"], "brdf_table")
        assert m["error"]["value"] == pytest.approx(inputs["table_summary"]["error"], rel=1e-9)
        assert m["error"]["lmax"] == 2 and m["error"]["views"] == 32
        assert err.startswith(f"{inputs['table']}: error {m['error']['value']:.2e} ")

    @pytest.mark.parametrize("first", ["env", "sky"])
    def test_env_and_table_batch(self, tmp_path, run_cli, inputs, first):
        """``ENV.h5 TABLE.h5 --env ENV.h5`` (and a map beside the table): the ``env_sh`` asset
        is measured against its own source map, the whole irradiance SH webgl draws (lmax 4:
        what ``project-env --report`` measured of the asset, not the 9 coefficients of the
        engine targets); no file left but the exports."""
        code, out, err = run_cli("export", inputs[first], inputs["table"], "--to", "webgl",
                                 "--out-dir", tmp_path / "d", "--env", inputs["env"], "--report",
                                 "--json")  # fmt: skip
        assert code == 0, err
        assert listing(tmp_path / "d") == sorted([first, "table"])
        summary = json.loads(out)
        kinds = [m["kind"] for m in summary["measured"]]
        assert kinds == (["env_sh", "brdf_table"] if first == "env" else ["brdf_table"])
        if first == "env":
            head = summary["measured"][0]["error"]
            parts = inputs["env_summary"]["report"]["error_vs_brute_force"]
            assert head["value"] == pytest.approx(parts["irradiance"]["relative_rms"], rel=1e-9)
            assert head["quantity"] == "irradiance of the asset (its irradiance SH + lights)"
        else:
            assert [b["input"] for b in summary["bakes"]] == [inputs["sky"]]

    def test_unmeasured_input_says_so(self, tmp_path, run_cli, inputs):
        """A MERL table's BRDF is a file export does not read: one line says it is not
        measured, and why; exit 0."""
        code, out, err = run_cli("export", inputs["merl"], "--to", "webgl", "-o", tmp_path / "d",
                                 "--env", inputs["env"], "--report", "--json")  # fmt: skip
        assert code == 0, err
        (m,) = json.loads(out)["measured"]
        assert (m["kind"], m["error"]) == ("brdf_table", None)
        assert err.startswith(f"{inputs['merl']}: not measured (brdf_table: a measured BRDF, "
                              "whose MERL file")  # fmt: skip

    def test_probes_measured_as_probe_fit_measured_them(self, tmp_path, run_cli, sky):
        """An SH-exp probe and a set of two: probe-fit's headline of each (its error against
        brute force, printed when it fitted them), the set by its worst probe; one line each."""
        other = str(write_test_exr(tmp_path / "dim.exr", np.full((32, 64, 3), 0.25)))
        fitted, probe = {}, tmp_path / "one" / "sky.h5"
        for name, maps, out_arg in (("one", [sky], ["--out-dir", tmp_path / "one"]),
                                    ("two", [sky, other], ["-o", tmp_path / "two.h5"])):
            code, out, err = run_cli("probe-fit", *maps, *out_arg, "--samples", "256", "--json",
                                     "-q")  # fmt: skip
            assert code == 0, err
            fitted[name] = [p["error"]["value"] for p in json.loads(out)["probes"]]
        code, out, err = run_cli("export", probe, tmp_path / "two.h5", "--to", "webgl",
                                 "--out-dir", tmp_path / "d", "--report", "--json")  # fmt: skip
        assert code == 0, err
        one, two = json.loads(out)["measured"]
        assert (one["kind"], two["kind"]) == ("shexp_probe", "shexp_probe_set")
        assert one["error"]["value"] == pytest.approx(fitted["one"][0], rel=1e-9)
        assert two["error"]["by_probe"] == pytest.approx(fitted["two"], rel=1e-9)
        assert two["error"]["value"] == pytest.approx(max(fitted["two"]), rel=1e-9)
        lines = err.splitlines()
        assert lines[0].startswith(f"{probe}: error {one['error']['value']:.2%} "
                                   "(relative RMS of luminance vs brute force) of the glossy E0")
        assert lines[1].endswith("over its α range, the worst of 2 probes")

    def test_shrm_measured_as_its_preview_measures_it(self, tmp_path, run_cli, sky):
        """An SHRM: its shading of a 24² sphere against brute force of its map, the same
        figure as ``preview --diff`` of that sphere (the preview's pass and reference, another
        path through the code)."""
        shrm = tmp_path / "s.h5"
        code, _, err = run_cli("shrm", sky, "-o", shrm, "-p", "sigma=0.4", "--face-size", "16",
                               "-q")  # fmt: skip
        assert code == 0, err
        code, out, err = run_cli("export", shrm, "--to", "webgl", "-o", tmp_path / "d",
                                 "--report", "--json")  # fmt: skip
        assert code == 0, err
        (m,) = json.loads(out)["measured"]
        code, pv, err = run_cli("preview", shrm, "-o", tmp_path / "p.exr", "--size", "24",
                                "--diff", "--json", "-q")  # fmt: skip
        assert code == 0, err
        assert m["error"]["value"] == pytest.approx(json.loads(pv)["relative_rms_error"],
                                                    rel=1e-6)  # fmt: skip
