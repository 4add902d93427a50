"""Issue 11: hostile inputs, corrupt assets, full disks and signals on every command — here
items 1–4: an output that is an input, output locations checked before any work, a full disk,
all companion outputs or none, special files (no hang). The other items: the files beside
this one in tests/system/faults/.

Every failure case checks the same promise: exit 1 (2 for usage errors, 130/143 for
signals), exactly one ``shbake: error:`` line and no traceback, no hang (subprocess
cases are time-limited), no new file (temporaries included) and every pre-existing
file byte-identical. Cases that could hang or crash the interpreter run in a
subprocess; the rest run in-process (``run_cli``). Full-disk and read-only cases use a
small tmpfs when the tests run as root, else a file size limit (``EFBIG`` on every write
past a file's end) / an injected read-only check: no case is skipped.
"""

import errno
import os
import shutil
import stat
import subprocess

import h5py
import numpy as np
import pytest

from tests.assets_examples import write_map
from tests.faults import assert_failed, file_size_limit, fill, shbake, unchanged

# -- 1. output = input; output locations checked before any work --------------------------


class TestOutputIsInput:
    """Item 1: an output that is an input (same inode, through links, in lists) is refused."""

    def test_project_env(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("project-env", box / "map.exr", "-o", box / "map.exr"),
                          fragment="destroy the input")  # fmt: skip

    def test_split_sum_through_symlink(self, run_cli, box):
        (box / "link.exr").symlink_to(box / "map.exr")
        with unchanged(box):
            assert_failed(run_cli("split-sum", box / "link.exr", "-o", box / "map.exr"),
                          fragment="destroy the input")  # fmt: skip

    def test_hard_link(self, run_cli, box):
        os.link(box / "map.exr", box / "hard.exr")
        with unchanged(box):
            assert_failed(run_cli("project-env", box / "map.exr", "-o", box / "hard.exr"),
                          fragment="destroy the input")  # fmt: skip

    def test_brdf_table_merl(self, run_cli, box):
        from tests.helpers import write_merl

        merl = box / "m.binary"
        write_merl(merl, np.full((3, 90, 90, 180), 0.1))
        with unchanged(box):
            assert_failed(run_cli("brdf-table", "merl", "--merl", merl, "-o", merl),
                          fragment="destroy the input")  # fmt: skip

    def test_probe_list_line(self, run_cli, box):
        (box / "list.txt").write_text("map.exr map.exr\n")
        with unchanged(box):
            assert_failed(run_cli("probe-fit", "--list", box / "list.txt"),
                          fragment="destroy the input")  # fmt: skip

    def test_probe_eval_markdown(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("probe-eval", box / "map.exr", "--markdown", box / "map.exr"),
                          fragment="destroy the input")  # fmt: skip

    def test_preview_diff_onto_source(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("preview", box / "env.h5", "--diff", "--size", 8,
                                  "-o", box / "map.exr"))  # fmt: skip


class TestOutputLocations:
    """Items 1 and 8: empty, folder, missing or file parent, read-only — refused before work."""

    COMMANDS = {
        "project-env": ["project-env", "{map}"],
        "split-sum": ["split-sum", "{map}"],
        "brdf-table": ["brdf-table", "phong"],
        "preview": ["preview", "{env}"],
    }

    def _args(self, box, name):
        return [a.format(map=box / "map.exr", env=box / "env.h5") for a in self.COMMANDS[name]]

    @pytest.mark.parametrize("name", list(COMMANDS))
    @pytest.mark.parametrize("where", ["empty", "directory", "missing-parent", "file-parent"])
    def test_bad_output(self, run_cli, box, name, where):
        (box / "afile").write_text("x")
        out = {"empty": "", "directory": str(box), "missing-parent": str(box / "no" / "x.h5"),
               "file-parent": str(box / "afile" / "x.h5")}[where]  # fmt: skip
        with unchanged(box):  # click refuses a folder for a file option: a usage error
            assert_failed(run_cli(*self._args(box, name), "-o", out),
                          code=2 if where == "directory" else 1)  # fmt: skip

    @pytest.mark.parametrize("name", list(COMMANDS))
    def test_fifo_output(self, run_cli, box, name):
        """A special file as output is refused (its temporary would replace it: as root,
        ``-o /dev/null`` would have replaced the device)."""
        os.mkfifo(box / "out.fifo")
        with unchanged(box):
            assert_failed(run_cli(*self._args(box, name), "-o", box / "out.fifo"),
                          fragment="is a FIFO, not a regular file")  # fmt: skip
        assert stat.S_ISFIFO(os.stat(box / "out.fifo").st_mode)

    def test_exr_dir_under_a_file(self, run_cli, box):
        (box / "afile").write_text("x")
        with unchanged(box):
            assert_failed(
                run_cli(
                    "project-env",
                    box / "map.exr",
                    "-o",
                    box / "e.h5",
                    "--exr-dir",
                    box / "afile" / "maps",
                ),
                fragment="not a folder",
            )

    def test_out_dir_under_a_file(self, run_cli, box):
        (box / "afile").write_text("x")
        with unchanged(box):
            assert_failed(run_cli("probe-fit", box / "map.exr", "--out-dir", box / "afile" / "d"),
                          fragment="not a folder")  # fmt: skip

    @pytest.mark.parametrize("option", ["-o", "--markdown"])
    def test_empty_set_or_markdown(self, run_cli, box, option):
        cmd = "probe-fit" if option == "-o" else "probe-eval"
        with unchanged(box):
            assert_failed(run_cli(cmd, box / "map.exr", option, ""), fragment="empty")

    def test_injected_erofs(self, run_cli, box, monkeypatch):
        """Without root: the file system reports read-only."""
        from shbake.format import atomic

        monkeypatch.setattr(atomic, "_read_only_fs", lambda folder: True)
        with unchanged(box):
            assert_failed(run_cli("project-env", box / "map.exr", "-o", box / "env.h5"),
                          fragment="read-only")  # fmt: skip

    def test_read_only_file_system(self, run_cli, box, tmpfs, monkeypatch):
        """A read-only tmpfs (root), else a folder the file system check reports read-only."""
        from shbake.format import atomic

        tmpfs, mounted = tmpfs
        (tmpfs / "old.h5").write_bytes((box / "env.h5").read_bytes())
        remount = ["mount", "-o", "remount,ro", str(tmpfs)]
        if not (mounted and subprocess.run(remount, capture_output=True).returncode == 0):
            real = atomic._read_only_fs
            monkeypatch.setattr(atomic, "_read_only_fs",
                                lambda f: str(f).startswith(str(tmpfs)) or real(f))  # fmt: skip
        with unchanged(tmpfs, box):
            assert_failed(run_cli("project-env", box / "map.exr", "-o", tmpfs / "old.h5"),
                          fragment="read-only")  # fmt: skip
            assert_failed(run_cli("probe-fit", box / "map.exr", "--out-dir", tmpfs / "d"),
                          fragment="read-only")  # fmt: skip


# -- 2. full disk ----------------------------------------------------------------------------


class TestFullDisk:
    """Item 2: a full disk is one line naming the file, never a segfault; old files survive."""

    CASES = {
        "project-env": ["project-env", "{map}", "-o", "{out}/old.h5", "--exr-dir", "{out}/maps"],
        "split-sum": ["split-sum", "{map}", "-o", "{out}/old.h5", "--size", "16", "--min-size",
                      "8", "--alphas", "0.25,1", "--samples", "64"],
        "brdf-table": ["brdf-table", "phong", "-o", "{out}/old.h5", "--size", "8", "--lmax", "2",
                       "--samples", "64", "--exr-dir", "{out}/bands"],
        "preview": ["preview", "{env}", "-o", "{out}/p.exr", "--size", "8", "--png"],
    }  # fmt: skip

    @pytest.mark.parametrize("name", list(CASES))
    def test_tmpfs(self, box, tmpfs, name):
        """A filled 2 MB tmpfs (root); else every write past a file's end fails (the
        process's file size limit, after a first run has filled the numba caches)."""
        tmpfs, mounted = tmpfs
        (tmpfs / "old.h5").write_bytes((box / "env.h5").read_bytes())

        def args(out):
            return [a.format(map=box / "map.exr", env=box / "env.h5", out=out)
                    for a in self.CASES[name]]  # fmt: skip

        if mounted:
            fill(tmpfs)
            run, fragment = (lambda: shbake(*args(tmpfs))), "no space left on device writing"
        else:
            (box / "warm").mkdir()
            assert shbake(*args(box / "warm"))[0] == 0
            shutil.rmtree(box / "warm")
            run, fragment = (lambda: shbake(*args(tmpfs), preexec=file_size_limit)), "writing"
        with unchanged(tmpfs, box):
            assert_failed(run(), fragment=fragment)

    def test_injected_enospc(self, run_cli, box, monkeypatch):
        """Without root: the write of the asset's bytes (built in memory by HDF5) stops half
        way with ENOSPC."""
        import shbake.format.asset as asset_module

        class FullDisk:
            def __init__(self, path, mode):
                self.file = open(path, mode)  # noqa: SIM115

            def write(self, data):
                self.file.write(data[: len(data) // 2])
                raise OSError(errno.ENOSPC, "No space left on device")

            def __enter__(self):
                return self

            def __exit__(self, *exc):
                self.file.close()

        monkeypatch.setattr(asset_module, "open", FullDisk, raising=False)
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        with unchanged(box):
            assert_failed(run_cli("project-env", box / "map.exr", "-o", box / "old.h5"),
                          fragment="no space left on device writing")  # fmt: skip


# -- 3. companion files: all outputs or none ----------------------------------------------


class TestCompanionFiles:
    """Item 3: when an EXR map, export or image fails, the asset is not written either."""

    def test_map_name_is_a_directory(self, run_cli, box):
        (box / "maps" / "irradiance.exr").mkdir(parents=True)
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        with unchanged(box):
            assert_failed(run_cli("project-env", box / "map.exr", "-o", box / "old.h5",
                                  "--exr-dir", box / "maps"), fragment="directory")  # fmt: skip

    def test_export_name_is_a_directory(self, run_cli, box):
        (box / "old-threejs" / "old.json").mkdir(parents=True)  # where --export threejs writes
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        with unchanged(box):
            assert_failed(run_cli("project-env", box / "map.exr", "-o", box / "old.h5",
                                  "--export", "threejs"), fragment="directory")  # fmt: skip

    def test_half_overflow(self, run_cli, box):
        write_map(box / "bright.exr", scale=1e6)
        with unchanged(box):
            assert_failed(run_cli("project-env", box / "bright.exr", "-o", box / "old.h5",
                                  "--exr-dir", box / "maps"), fragment="half")  # fmt: skip

    def test_preview_second_image_fails(self, run_cli, box):
        (box / "p-reference.exr").mkdir()
        with unchanged(box):
            assert_failed(run_cli("preview", box / "env.h5", "--diff", "--size", 8,
                                  "-o", box / "p.exr"), fragment="directory")  # fmt: skip


# -- 4. special files: no hang -----------------------------------------------------------


class TestSpecialFiles:
    """Item 4: FIFOs and devices are refused before opening (these would hang)."""

    @pytest.fixture
    def fifo(self, box):
        p = box / "pipe"
        os.mkfifo(p)
        return p

    def test_fifo_merl(self, box, fifo):
        assert_failed(shbake("brdf-table", "merl", "--merl", fifo, "-o", box / "t.h5",
                             timeout=60), fragment="FIFO")  # fmt: skip

    def test_fifo_list(self, box, fifo):
        assert_failed(shbake("probe-fit", "--list", fifo, timeout=60), fragment="FIFO")

    def test_fifo_asset(self, box, fifo):
        assert_failed(shbake("preview", fifo, "-o", box / "p.exr", timeout=60), fragment="FIFO")

    def test_fifo_source(self, box, fifo):
        assert_failed(shbake("preview", box / "env.h5", "--diff", "--source", fifo, "--size", 8,
                             "-o", box / "p.exr", timeout=60), fragment="FIFO")  # fmt: skip

    def test_dev_zero_source(self, box):
        assert_failed(
            shbake(
                "preview",
                box / "env.h5",
                "--diff",
                "--source",
                "/dev/zero",
                "--size",
                8,
                "-o",
                box / "p.exr",
                timeout=60,
            ),
            fragment="device",
        )

    @pytest.mark.parametrize("command", ["plan", "bake"])
    def test_fifo_scene(self, box, fifo, command):
        with unchanged(box):
            assert_failed(shbake(command, fifo, timeout=60), code=2, fragment="FIFO")

    def test_dev_zero_scene(self, box):
        """Read without a bound, ``/dev/zero`` as a scene grew without limit (12 GB)."""
        assert_failed(shbake("plan", "/dev/zero", timeout=60), code=2, fragment="device")

    def test_scene_state_fifo_not_read(self, fifo):
        """A FIFO where the lock or a stamp should be is treated as missing, not read."""
        from shbake.batch import scene_bake

        assert scene_bake.read_lock(str(fifo)) == {}

    def test_plan_hash_refuses_special_files(self, fifo):
        from shbake.batch.plan import file_hash
        from shbake.errors import ShbakeError

        for path in (fifo, "/dev/zero"):
            with pytest.raises(ShbakeError, match="not a regular file"):
                file_hash(str(path))

    @pytest.mark.parametrize(("recorded", "fragment"), [("/dev/zero", "is not named as an image"),
                                                        ("zero.exr", "device")])  # fmt: skip
    def test_recorded_source_dev_zero(self, box, recorded, fragment):
        """``/dev/zero`` is not followed (not an image's name); a link named like one is
        refused as a device before it is opened."""
        os.symlink("/dev/zero", box / "zero.exr")
        with h5py.File(box / "env.h5", "r+") as f:
            f.attrs["source_path"] = recorded
        assert_failed(shbake("preview", box / "env.h5", "--diff", "--size", 8,
                             "-o", box / "p.exr", timeout=60), fragment=fragment)  # fmt: skip
