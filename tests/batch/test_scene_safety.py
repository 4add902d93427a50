"""Issue 27: a scene run never writes over its inputs, refuses hostile scenes in one line
and shrugs off a poisoned lock.

Every refusal checks the promise of docs/CLI.md: its exit status, exactly one
``shbake: error:`` line, no traceback, and the folder byte-identical (no new file, no
temporary, no empty folder). The scenes use a 16×32 map, so planning takes a moment.
"""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from shbake.batch.scene import load_scene
from tests.faults import assert_failed, unchanged
from tests.helpers import write_test_exr

DIFFUSE = '[[materials]]\nname = "plaster"\nkind = "diffuse"\n'


def tiny_scene(folder: Path, text: str, name: str = "scene.toml", maps=("maps/sky.exr",)):
    """``text`` (a scene, plus one diffuse material) at ``folder/name``, with 16×32 maps."""
    for m in maps:
        (folder / m).parent.mkdir(parents=True, exist_ok=True)
        write_test_exr(folder / m, np.full((16, 32, 3), 0.5, np.float32))
    path = folder / name
    path.write_text(text + DIFFUSE)
    return path


def link(kind: str, target: Path, path: Path) -> None:
    """``path`` made a symbolic or a hard link to ``target``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "symlink":
        path.symlink_to(os.path.relpath(target, path.parent))
    else:
        os.link(target, path)


class TestInputsNeverOutputs:
    """Item 4 / deliverable 5: the scene, its maps and the lock are registered before any
    output is planned; an output that is one of them (same path, a symbolic or a hard
    link) is refused before any work, in every command, ``bake`` included."""

    def test_scene_named_like_the_lock(self, tmp_path, run_cli):
        # the lock (out_dir/scene.lock.json) would replace the scene itself
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "."\n[[environments]]\n'
                          'map = "maps/sky.exr"\n', name="scene.lock.json")  # fmt: skip
        with unchanged(tmp_path):
            assert_failed(run_cli("bake", path), fragment="destroy the input")

    @pytest.mark.parametrize("kind", ["symlink", "hardlink"])
    def test_lock_linked_to_the_scene(self, tmp_path, run_cli, kind):
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "."\n[[environments]]\n'
                          'map = "maps/sky.exr"\n')  # fmt: skip
        link(kind, path, tmp_path / "scene.lock.json")
        with unchanged(tmp_path):
            assert_failed(run_cli("bake", path), fragment="destroy the input")

    @pytest.mark.parametrize("where", ["env_sh/sky.h5", "env_sh/*.h5"])
    def test_map_where_its_asset_goes(self, tmp_path, run_cli, where):
        # the map's env_sh asset is out_dir/env_sh/sky.h5: named there, or globbed there
        path = tiny_scene(tmp_path, f'[scene]\nout_dir = "."\n[[environments]]\nmap = "{where}"\n',
                          maps=())  # fmt: skip
        (tmp_path / "env_sh").mkdir()
        (tmp_path / "env_sh" / "sky.h5").write_bytes(b"the map's bytes")
        for command in ("plan", "bake"):
            with unchanged(tmp_path):
                line = assert_failed(run_cli(command, path), code=2)
            assert f"{path}:4: environments[0].map: " in line

    @pytest.mark.parametrize("kind", ["symlink", "hardlink"])
    def test_asset_linked_to_the_map(self, tmp_path, run_cli, kind):
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "."\n[[environments]]\n'
                          'map = "maps/sky.exr"\n')  # fmt: skip
        link(kind, tmp_path / "maps" / "sky.exr", tmp_path / "env_sh" / "sky.h5")
        for args in (["bake", path], ["plan", path, "--emit-make", tmp_path / "scene.mk"]):
            with unchanged(tmp_path):
                assert_failed(run_cli(*args), fragment="destroy the input")

    def test_fragment_over_the_scene(self, tmp_path, run_cli):
        path = tiny_scene(tmp_path, '[[environments]]\nmap = "maps/sky.exr"\n')
        with unchanged(tmp_path):
            assert_failed(run_cli("plan", path, "--emit-make", path), fragment="destroy the input")

    @pytest.mark.parametrize("linked", ["out/env_sh", "out/.stamps/env_sh"])
    def test_linked_subfolder_of_out_dir(self, tmp_path, run_cli, linked):
        """A symbolic link inside out_dir (an asset folder, the stamps' folder) does not carry
        the run's writes out of it: refused before any work, the outside folder untouched."""
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "out"\n[[environments]]\n'
                          'map = "maps/sky.exr"\n')  # fmt: skip
        (tmp_path / "elsewhere").mkdir()
        (tmp_path / linked).parent.mkdir(parents=True)
        (tmp_path / linked).symlink_to(tmp_path / "elsewhere")
        for args in (["bake", path], ["plan", path, "--emit-make", tmp_path / "scene.mk"]):
            with unchanged(tmp_path):
                assert_failed(run_cli(*args), fragment="a symbolic link takes it out")

    @pytest.mark.parametrize("target", ["out/scene.lock.json", "out/env_sh/sky.h5",
                                        "out/.stamps/env_sh/sky.json"])  # fmt: skip
    def test_fragment_over_what_the_bake_writes(self, tmp_path, run_cli, target):
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "out"\n[[environments]]\n'
                          'map = "maps/sky.exr"\n')  # fmt: skip
        code, _, err = run_cli("bake", path, "--quiet")
        assert code == 0, err
        with unchanged(tmp_path):
            assert_failed(run_cli("plan", path, "--emit-make", tmp_path / target),
                          fragment="which the scene's bake writes")  # fmt: skip

    def test_glob_never_matches_the_lock(self, tmp_path, run_cli):
        # out_dir "data" and maps "data/*": the lock and the assets the first bake wrote
        # there are not maps; a second bake bakes nothing
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "data"\n[[environments]]\n'
                          'map = "data/*"\n', maps=("data/sky.exr",))  # fmt: skip
        code, _, err = run_cli("bake", path, "--quiet")
        assert code == 0, err
        assert (tmp_path / "data" / "scene.lock.json").is_file()
        assert [e.name for e in load_scene(str(path)).environments] == ["sky"]
        code, _, err = run_cli("bake", path, "--json", "--quiet")
        assert code == 0, err


def copy_baked(baked: Path, tmp_path: Path) -> Path:
    """A copy of the baked scene folder whose lock names the copy's map (up to date)."""
    folder = tmp_path / "scene"
    shutil.copytree(baked, folder, symlinks=True)
    lock_file = folder / "out" / "scene.lock.json"
    lock_file.write_text(lock_file.read_text().replace(str(baked), str(folder)))
    return folder


@pytest.fixture(scope="module")
def baked(tmp_path_factory) -> Path:
    """A folder with a one-map scene baked into ``out``."""
    from shbake_cli.main import main

    folder = tmp_path_factory.mktemp("poisoned")
    path = tiny_scene(folder, '[scene]\nout_dir = "out"\n[[environments]]\n'
                      'map = "maps/sky.exr"\n')  # fmt: skip
    assert main(["bake", str(path), "--quiet"]) == 0
    return folder


class TestPoisonedLock:
    """Item 12: a lock record whose outputs name a special file, a folder or a path outside
    the asset's folder is ignored with one warning and the asset baked again."""

    @pytest.mark.parametrize("poison", ["/dev/zero", "fifo", "folder", "../../maps/sky.exr",
                                        "link", "not a record"])  # fmt: skip
    def test_rebaked_with_one_warning(self, baked, tmp_path, run_cli, poison):
        folder = copy_baked(baked, tmp_path)
        path = folder / "scene.toml"
        lock_file = folder / "out" / "scene.lock.json"
        lock = json.loads(lock_file.read_text())
        asset = folder / "out" / "env_sh" / "sky.h5"
        good = asset.read_bytes()
        record = lock["assets"]["env_sh/sky"]
        if poison == "fifo":
            os.mkfifo(folder / "out" / "env_sh" / "pipe")
            record["outputs"]["pipe"] = "0" * 64
        elif poison == "folder":
            (folder / "out" / "env_sh" / "sub").mkdir()
            record["outputs"]["sub"] = "0" * 64
        elif poison == "link":
            (folder / "out" / "env_sh" / "zero").symlink_to("/dev/zero")
            record["outputs"]["zero"] = "0" * 64
        elif poison == "not a record":
            lock["assets"]["env_sh/sky"] = ["sky.h5"]
        else:
            record["outputs"][poison] = "0" * 64
        lock_file.write_text(json.dumps(lock))
        code, _, err = run_cli("bake", path)
        assert code == 0, err
        warnings = [x for x in err.splitlines() if x.startswith("shbake: warning:")]
        assert len(warnings) == 1 and "env_sh/sky" in warnings[0], err
        assert "baked env_sh/sky" in err
        assert asset.read_bytes() == good  # the same bytes again
        clean = json.loads(lock_file.read_text())["assets"]["env_sh/sky"]
        assert set(clean["outputs"]) == {"sky.h5"}
        # and the lock is whole again: the next bake bakes nothing, silently
        code, _, err = run_cli("bake", path)
        assert code == 0 and "shbake: warning" not in err and "0 baked" in err, err

    def test_lock_that_is_not_a_lock(self, baked, tmp_path, run_cli):
        folder = copy_baked(baked, tmp_path)
        (folder / "out" / "scene.lock.json").write_text("[" * 100000 + "]" * 100000)
        code, _, err = run_cli("bake", folder / "scene.toml")
        assert code == 0 and "1 baked" in err, err


class TestBakeAssetStamp:
    """``bake --asset ID`` (what make's rules run) takes only a stamp shbake could have
    written for this scene: a stamp whose output or inputs point elsewhere is refused."""

    def test_stamp_pointing_elsewhere(self, tmp_path, run_cli):
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "out"\n[[environments]]\n'
                          'map = "maps/sky.exr"\n')  # fmt: skip
        code, _, err = run_cli("plan", path, "--emit-make", tmp_path / "scene.mk", "--quiet")
        assert code == 0, err
        stamp = tmp_path / "out" / ".stamps" / "env_sh" / "sky.json"
        good = json.loads(stamp.read_text())
        for key, value in (("output", str(tmp_path / "victim.h5")),
                           ("inputs", ["/etc/passwd"]), ("id", "env_sh/other")):  # fmt: skip
            stamp.write_text(json.dumps(dict(good, **{key: value})))
            with unchanged(tmp_path):
                assert_failed(run_cli("bake", path, "--asset", "env_sh/sky"),
                              fragment="not a settings stamp")  # fmt: skip
        for aid in ("../../x", "env_sh/..", "env_sh/sky/../../x", "-x"):
            with unchanged(tmp_path):
                assert_failed(run_cli("bake", path, f"--asset={aid}"), fragment="not an asset id")


class TestEmitMakeFailsCleanly:
    """Item 14: ``plan --emit-make`` into a path it cannot write leaves nothing behind (it
    left ``scene-assets/.stamps``), and is refused before planning."""

    @pytest.mark.parametrize("where, code", [("missing/scene.mk", 1), ("afile/scene.mk", 1),
                                             ("folder", 2)])  # fmt: skip
    def test_nothing_written(self, tmp_path, run_cli, where, code):
        path = tiny_scene(tmp_path, '[[environments]]\nmap = "maps/sky.exr"\n')
        (tmp_path / "afile").write_text("a file, not a folder\n")
        (tmp_path / "folder").mkdir()
        with unchanged(tmp_path):
            assert_failed(run_cli("plan", path, "--emit-make", tmp_path / where), code=code)

    def test_failed_asset_leaves_no_folder(self, tmp_path, run_cli):
        # the folder a recipe creates for its asset goes again when the bake fails
        path = tiny_scene(tmp_path, '[scene]\nout_dir = "out"\n[[environments]]\n'
                          'map = "maps/sky.exr"\n')  # fmt: skip
        code, _, err = run_cli("plan", path, "--emit-make", tmp_path / "scene.mk", "--quiet")
        assert code == 0, err
        (tmp_path / "maps" / "sky.exr").write_bytes(b"not an image")
        with unchanged(tmp_path):
            assert_failed(run_cli("bake", path, "--asset", "env_sh/sky"))


class TestIssueInjections:
    """Item 1, as filed: ``make scene-assets`` ran ``touch INJECTED`` from a map folder's
    name and from the scene file's name. Now refused in one line (exit 2), nothing written,
    and make never runs anything else."""

    def check(self, folder: Path, run_cli, scene: Path):
        frag = folder / "scene.mk"
        code, _, err = run_cli("plan", scene, "--emit-make", frag, "--quiet")
        if frag.exists():  # the old code: what make does with the fragment
            (folder / "Makefile").write_text(f"include {frag}\n")
            subprocess.run(["make", "scene-assets", "SHBAKE=true"], cwd=folder,
                           capture_output=True, timeout=60)  # fmt: skip
        assert not [p for p in folder.rglob("INJECTED*")], "make ran an injected command"
        assert code == 2 and err.count("\n") == 1, err
        assert not frag.exists() and not (folder / "scene-assets").exists()

    def test_map_folder_name(self, tmp_path, run_cli):
        evil = "hdri/sky\n\ttouch\tINJECTED\n\t-/studio.exr"
        scene = tiny_scene(tmp_path, '[[environments]]\nmap = "hdri/*/*.exr"\n', maps=(evil,))
        (tmp_path / "hdri" / "sky").write_text("")  # so that make reaches the recipe
        self.check(tmp_path, run_cli, scene)

    def test_scene_file_name(self, tmp_path, run_cli):
        scene = tiny_scene(tmp_path, '[[environments]]\nmap = "maps/*.exr"\n',
                           name="scene;touch\tINJECTED2;.toml")  # fmt: skip
        self.check(tmp_path, run_cli, scene)
