"""Issue 11: hostile inputs, corrupt assets, full disks and signals on every command.

Every failure case checks the same promise: exit 1 (2 for usage errors, 130/143 for
signals), exactly one ``shbake: error:`` line and no traceback, no hang (subprocess
cases are time-limited), no new file (temporaries included) and every pre-existing
file byte-identical. Cases that could hang or crash the interpreter run in a
subprocess; the rest run in-process (``run_cli``). Full-disk and read-only cases use a
small tmpfs when the tests run as root, else a file size limit (``EFBIG`` on every write
past a file's end) / an injected read-only check: no case is skipped.
"""

import contextlib
import errno
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from shbake.format.asset import write_asset
from tests.assets_examples import CORRUPTIONS, corrupt, example, write_map
from tests.faults import (
    PREVIEW_OF_KIND,
    TIMEOUT,
    TMPFS_SIZE,
    assert_failed,
    can_mount,
    file_size_limit,
    fill,
    shbake,
    snapshot,
    unchanged,
)


def dead_pid() -> int:
    """A process id that does not exist."""
    pid = 4_000_000
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return pid
        except PermissionError:
            pass
        pid -= 1


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """A workspace: a tiny map, an env_sh asset of it, old outputs, a probe and a table."""
    root = tmp_path_factory.mktemp("faults")
    m = write_map(root / "map.exr")
    write_map(root / "other.exr", seed=3)
    for kind in ("env_sh", "shexp_probe", "splitsum_probe", "brdf_table"):
        write_asset(str(root / f"{kind}.h5"), example(kind, m))
    (root / "old.h5").write_bytes((root / "env_sh.h5").read_bytes())
    return root


@pytest.fixture
def box(tmp_path, ws):
    """A fresh folder with a copy of the map and of the env_sh asset."""
    (tmp_path / "map.exr").write_bytes((ws / "map.exr").read_bytes())
    (tmp_path / "env.h5").write_bytes((ws / "env_sh.h5").read_bytes())
    return tmp_path


@pytest.fixture
def tmpfs(tmp_path):
    """A folder on a 2 MB tmpfs when the tests may mount one (root), else a plain folder;
    ``(folder, mounted)``. Tests inject the fault themselves when ``mounted`` is false, so
    every case runs for every user."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    mounted = can_mount() and subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={TMPFS_SIZE}", "tmpfs", str(mnt)],
        capture_output=True,
    ).returncode == 0  # fmt: skip
    try:
        yield mnt, mounted
    finally:
        if mounted:
            subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


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

    def test_recorded_source_dev_zero(self, box):
        with h5py.File(box / "env.h5", "r+") as f:
            f.attrs["source_path"] = "/dev/zero"
        assert_failed(shbake("preview", box / "env.h5", "--diff", "--size", 8,
                             "-o", box / "p.exr", timeout=60), fragment="device")  # fmt: skip


# -- 5. memory bombs -------------------------------------------------------------------------


def _huge_header_exr(path: Path, width: int, height: int) -> None:
    """A tiny EXR whose header claims ``width × height`` (pixels never written)."""
    write_map(path)
    data = bytearray(path.read_bytes())
    for name in (b"dataWindow\0box2i\0", b"displayWindow\0box2i\0"):
        i = data.index(name) + len(name) + 4
        data[i : i + 16] = np.array([0, 0, width - 1, height - 1], "<i4").tobytes()
    path.write_bytes(bytes(data))


class TestMemory:
    """Item 5: estimates refused above the budget; readers never load undeclared data."""

    def test_merl_dev_zero(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("brdf-table", "merl", "--merl", "/dev/zero", "-o",
                                  box / "t.h5"), fragment="device")  # fmt: skip

    def test_unwritten_huge_dataset_ignored(self, run_cli, box):
        with h5py.File(box / "env.h5", "r+") as f:
            f.create_dataset("/extra", shape=(35000, 35000), dtype="f8")
        code, _, err = run_cli("preview", box / "env.h5", "-o", box / "p.exr", "--size", 8, "-q")
        assert code == 0, err

    def test_huge_decoded_image(self, run_cli, box):
        _huge_header_exr(box / "huge.exr", 23168, 11584)
        with unchanged(box):  # OpenImageIO's header check or shbake's decoded-bytes guard
            assert_failed(run_cli("project-env", box / "huge.exr", "-o", box / "x.h5"))

    def test_decoded_bytes_guard(self, box, monkeypatch):
        from shbake.envmap import image_io
        from shbake.errors import ImageReadError

        monkeypatch.setattr(image_io, "MAX_DECODED_BYTES", 1000)
        with pytest.raises(ImageReadError, match="decodes to"):
            image_io.read_image(str(box / "map.exr"))

    def test_table_estimate(self, run_cli, box):
        with unchanged(box):
            msg = assert_failed(
                run_cli("brdf-table", "phong", "-o", box / "t.h5", "--size", 4096, "--lmax", 16),
                fragment="needs an estimated",
            )
        assert "GiB" in msg and "--max-memory" in msg

    def test_max_memory_option(self, run_cli, box):
        from shbake.resources import memory_budget

        with unchanged(box):
            assert_failed(run_cli("--max-memory", "4k", "project-env", box / "map.exr", "-o",
                                  box / "x.h5"), fragment="memory budget")  # fmt: skip
        # the budget was the run's: library calls after it in the same process (a test's
        # fixture reading a map) were refused at 4 KiB, in whichever order xdist ran them
        assert memory_budget() > 4096

    def test_max_memory_bad_value(self, run_cli, box):
        assert_failed(run_cli("--max-memory", "lots", "project-env", box / "map.exr", "-o",
                              box / "x.h5"), code=2, fragment="--max-memory")  # fmt: skip


def traced_peak(call) -> int:
    """Peak bytes numpy and Python allocate during ``call()`` (tracemalloc; numpy reports
    its buffers to it). An independent measurement of what an estimate predicts."""
    import tracemalloc

    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        call()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


class TestPreviewMemory:
    """Item 5 for ``preview``: ``--size``, the reference pass and kautz coefficients are
    estimated before any image is allocated; the estimate bounds the measured peak."""

    def test_size_refused(self, run_cli, box):
        with unchanged(box):
            msg = assert_failed(run_cli("--max-memory", "1G", "preview", box / "env.h5", "-o",
                                        box / "p.exr", "--size", 4096),
                                fragment="4096x4096 preview needs an estimated")  # fmt: skip
        assert "GiB" in msg and "--max-memory" in msg

    def test_reference_counted(self):
        from shbake.batch.preview import preview_memory

        assert preview_memory(512, reference=True) > preview_memory(512)
        assert preview_memory(512, texels=10**6) - preview_memory(512) == 160 * 10**6

    def test_kautz_coefficients_refused(self, run_cli, ws, box):
        from shbake.batch.preview import preview_memory

        need = preview_memory(2048, coeffs=9)  # the example table: lmax 2
        budget = (preview_memory(2048) + need) // 2
        with unchanged(box):
            assert_failed(run_cli("--max-memory", budget, "preview", box / "env.h5", "--pass",
                                  "kautz", "--table", ws / "brdf_table.h5", "-o", box / "p.exr",
                                  "--size", 2048), fragment="needs an estimated")  # fmt: skip

    @pytest.mark.parametrize("diff", [False, True])
    def test_estimate_bounds_measured_peak(self, box, diff):
        from shbake.batch.preview import preview_asset, preview_memory

        size = 256
        run = lambda: preview_asset(str(box / "env.h5"), str(box / "p.exr"), size=size,  # noqa: E731
                                    diff=diff, source=str(box / "map.exr"))  # fmt: skip
        run()  # compile / load caches outside the measurement
        peak = traced_peak(run)
        estimate = preview_memory(size, diff, texels=16 * 32)
        assert peak <= estimate <= 3 * peak, (peak, estimate)


class TestProjectEnvMemory:
    """Item 5 for ``project-env``: the ``--report`` sweep and the ``--exr-dir`` maps."""

    def test_report_refused_plain_run_accepted(self, run_cli, box):
        from shbake.batch.project_env import project_memory

        budget = project_memory(16 * 32, None, True) - 1  # the sweep alone does not fit
        code, _, err = run_cli("--max-memory", budget, "project-env", box / "map.exr",
                               "-o", box / "a.h5", "-q")  # fmt: skip
        assert code == 0, err
        with unchanged(box):
            assert_failed(run_cli("--max-memory", budget, "project-env", box / "map.exr", "-o",
                                  box / "b.h5", "--report"),
                          fragment="--report over 32x16")  # fmt: skip

    def test_exr_maps_refused(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("--max-memory", "1G", "project-env", box / "map.exr", "-o",
                                  box / "b.h5", "--exr-dir", box / "maps", "--size", 4096),
                          fragment="4096x8192 --exr-dir maps needs an estimated")  # fmt: skip

    def test_report_estimate_bounds_measured_peak(self, tmp_path):
        from shbake.batch.project_env import project_environment, project_memory
        from shbake.envmap import load_environment
        from tests.helpers import write_test_exr

        h = 128
        pixels = (0.5 + np.random.default_rng(2).random((h, 2 * h, 3))).astype(np.float32)
        write_test_exr(tmp_path / "m.exr", pixels)
        m = str(tmp_path / "m.exr")
        run = lambda rep: project_environment(m, str(tmp_path / "o.h5"), report=rep)  # noqa: E731
        run(True)
        base = traced_peak(lambda: load_environment(m, quiet=True))
        peak = traced_peak(lambda: run(True))
        estimate = base + project_memory(h * 2 * h, None, True)
        assert peak <= estimate <= 3 * peak, (peak, estimate)


class TestProbeFitMemory:
    """Item 5 for ``probe-fit``: the plan (per worker) and the fit's working arrays."""

    def test_plan_refused(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("--max-memory", "1G", "probe-fit", box / "map.exr", "--out-dir",
                                  box / "d", "--normals", 4096, "--views", 4096),
                          fragment="probe fit (4096 normals x 4096 views")  # fmt: skip

    def test_workers_multiply(self, run_cli, box):
        from shbake.bakers.shexp import FitConfig

        one = FitConfig().memory((16, 32), 1)
        with unchanged(box):
            assert_failed(run_cli("--max-memory", int(1.5 * one), "probe-fit", box / "map.exr",
                                  "--out-dir", box / "d", "--jobs", 2),
                          fragment="in each of 2 workers")  # fmt: skip

    @pytest.mark.parametrize("changes", [{}, {"lmax_p": 6, "lmax_q": 6}, {"targets": "sh"}])
    def test_estimate_bounds_measured_peak(self, changes):
        from shbake.bakers.shexp import FitConfig, FitPlan

        cfg = FitConfig(normals=16, views=8, samples=256, **changes)
        pixels = 0.5 + np.random.default_rng(0).random((64, 128, 3))
        FitPlan(cfg, pixels.shape[:2]).fit_many([pixels, pixels])  # compile outside
        peak = traced_peak(lambda: FitPlan(cfg, pixels.shape[:2]).fit_many([pixels, pixels]))
        estimate = cfg.memory(pixels.shape[:2], 2)
        assert peak <= estimate <= 4 * peak, (peak, estimate)


class TestOtherCommandsMemory:
    """Item 5 for split-sum, export and shrm: their size parameters are estimated first."""

    def test_split_sum_levels(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("--max-memory", "1G", "split-sum", box / "map.exr", "-o",
                                  box / "s.h5", "--size", 2048, "--min-size", 2048, "--alphas",
                                  ",".join(str(0.2 + 0.05 * i) for i in range(16))),
                          fragment="split-sum chain of 16 levels")  # fmt: skip

    def test_export_cube_size(self, run_cli, box):
        assert run_cli("project-env", box / "map.exr", "-o", box / "e.h5", "-q")[0] == 0
        with unchanged(box):
            assert_failed(run_cli("--max-memory", "1G", "export", box / "e.h5", "--to", "gltf",
                                  "-o", box / "x.gltf", "--size", 4096, "--floor", 8),
                          fragment="cube chain of 4096")  # fmt: skip

    def test_shrm_cube(self, run_cli, box):
        with unchanged(box):
            assert_failed(run_cli("--max-memory", "64M", "shrm", box / "map.exr", "-o",
                                  box / "r.h5", "--brdf", "phong", "--F", 4, "--P", 4,
                                  "--face-size", 256), fragment="SHRM with 25 terms")  # fmt: skip


# -- 6, 7 (and issue 10). corrupt assets ----------------------------------------------------


class TestCorruptAssets:
    """Items 6 and 7, issue 10: every corrupt asset is one line and exit 1 in every command
    that reads assets (preview of each kind; preview --table for tables)."""

    @pytest.mark.parametrize("case", list(CORRUPTIONS))
    def test_preview(self, run_cli, ws, tmp_path, case):
        path, fragment = corrupt(case, ws / "map.exr", tmp_path)
        kind = CORRUPTIONS[case][0]
        out = tmp_path / "p.exr"
        if kind == "brdf_table":
            args = ["preview", ws / "env_sh.h5", "--pass", "kautz", "--table", path, "-o", out,
                    "--size", 8]  # fmt: skip
        else:
            args = PREVIEW_OF_KIND[kind](path, out)
        with unchanged(tmp_path):
            assert_failed(run_cli(*args), fragment=fragment)

    @pytest.mark.parametrize("case", [c for c, v in CORRUPTIONS.items() if v[0] == "env_sh"])
    def test_export(self, run_cli, ws, tmp_path, case):
        path, fragment = corrupt(case, ws / "map.exr", tmp_path)
        with unchanged(tmp_path):
            assert_failed(run_cli("export", path, "--to", "threejs", "-o", tmp_path / "x.json"),
                          fragment=fragment)  # fmt: skip

    def test_truncated(self, run_cli, ws, tmp_path):
        data = (ws / "env_sh.h5").read_bytes()
        (tmp_path / "t.h5").write_bytes(data[: len(data) // 2])
        with unchanged(tmp_path):
            assert_failed(run_cli("preview", tmp_path / "t.h5", "-o", tmp_path / "p.exr"))

    def test_exr_renamed(self, run_cli, ws, tmp_path):
        (tmp_path / "m.h5").write_bytes((ws / "map.exr").read_bytes())
        with unchanged(tmp_path):
            assert_failed(run_cli("preview", tmp_path / "m.h5", "-o", tmp_path / "p.exr"),
                          fragment="not a readable HDF5 asset")  # fmt: skip

    def test_source_hash_mismatch(self, run_cli, ws, tmp_path):
        (tmp_path / "env.h5").write_bytes((ws / "env_sh.h5").read_bytes())
        with unchanged(tmp_path):
            assert_failed(run_cli("preview", tmp_path / "env.h5", "--diff", "--size", 8,
                                  "--source", ws / "other.exr", "-o", tmp_path / "p.exr"),
                          fragment="SHA-256")  # fmt: skip


# -- 8, 9. other tracebacks; one line ----------------------------------------------------


class TestOneLine:
    """Items 8 and 9: no traceback for odd inputs; warnings never add lines to an error."""

    def test_non_utf8_list(self, run_cli, box):
        (box / "list.txt").write_bytes(b"\xff\xfe map.exr\n")
        assert_failed(run_cli("probe-fit", "--list", box / "list.txt"), fragment="UTF-8")

    @pytest.mark.parametrize("option", ["--list", "--merl"])
    @pytest.mark.parametrize("what", ["missing", "symlink-loop"])
    def test_unreadable_list_or_merl_names_the_reason(self, run_cli, box, option, what):
        """Read errors of the probe list and the MERL file said ``(None)`` instead of why."""
        path = box / "x.txt"
        if what == "symlink-loop":
            os.symlink(box / "y.txt", path)
            os.symlink(path, box / "y.txt")
        args = (["probe-fit", "--list", path] if option == "--list"
                else ["brdf-table", "merl", "--merl", path, "-o", box / "t.h5"])  # fmt: skip
        with unchanged(box):
            msg = assert_failed(run_cli(*args))
        assert "None" not in msg
        assert ("no such file" if what == "missing" else "symbolic links") in msg

    @pytest.mark.parametrize("args", [
        ["preview", "{env}", "-o", "{box}/p.exr", "--roughness", "nan"],
        ["export", "{env}", "--to", "threejs", "-o", "{box}/x.json", "--sun-radius", "nan"],
        ["probe-fit", "{map}", "--out-dir", "{box}/d", "--floor", "nan"],
        ["shrm", "{map}", "-o", "{box}/o.h5", "--brdf", "phong", "--eps", "inf"],
        ["tradeoff", "env_sh", "--map", "{map}", "--tol", "nan", "-o", "{box}/t.png"],
    ])  # fmt: skip
    def test_nan_option_refused(self, run_cli, box, args):
        """click's range check compares, and every comparison with NaN is false: NaN passed
        every float option (and was then ignored or propagated)."""
        args = [a.format(env=box / "env.h5", map=box / "map.exr", box=box) for a in args]
        with unchanged(box):
            msg = assert_failed(run_cli(*args), code=2)
        assert "not a finite number" in msg or "is not in the range" in msg, msg

    def test_scheduler_not_a_url(self, run_cli, box):
        result = run_cli("probe-fit", box / "map.exr", "--out-dir", box / "d", "--scheduler",
                         "not a url")  # fmt: skip
        assert_failed(result, code=2, fragment="--scheduler")
        assert not (box / "d").exists()

    def test_json_stdout_full(self, box):
        with open("/dev/full", "w") as full:
            r = shbake("project-env", box / "map.exr", "-o", box / "e2.h5", "--json",
                       stdout=full, timeout=60)  # fmt: skip
        assert_failed(r, fragment="stdout")

    def test_warnings_then_error_is_one_line(self, capfd):
        import warnings

        from shbake_cli.guard import run

        from shbake.errors import InputError

        def call():
            warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
            np.float32(3e38) * np.float32(10)
            raise InputError("bad\nthings " + "x" * 2000)

        code = run(call, [])
        _, err = capfd.readouterr()
        assert_failed((code, "", err))
        assert len(err.splitlines()) == 1 and len(err) < 500

    def test_truncated_plan_cache_entry_rebuilt(self, tmp_path):
        from shbake.batch import plan_cache

        p = tmp_path / "plan-x.npz"
        p.write_bytes(b"PK\x03\x04 truncated")
        assert plan_cache._load(p) is None


# -- 10. signals --------------------------------------------------------------------------


LONG_TABLE = ["brdf-table", "phong", "--size", "256", "--lmax", "8", "--samples", "4096"]


@pytest.fixture(scope="module")
def big(tmp_path_factory):
    """A 256x512 map with an env_sh asset baked from it (references read the map), and a
    1024x2048 map (a long --report sweep)."""
    from shbake_cli.main import main

    from tests.helpers import write_test_exr

    root = tmp_path_factory.mktemp("big")
    rng = np.random.default_rng(7)
    write_test_exr(root / "big.exr", 0.2 + rng.random((256, 512, 3)))
    write_test_exr(root / "huge.exr", 0.2 + rng.random((1024, 2048, 3)))
    assert main(["project-env", str(root / "big.exr"), "-o", str(root / "big.h5"), "-q"]) == 0
    return root


class TestSignals:
    """Item 10: SIGINT/SIGTERM stop within about a second anywhere, clean up, exit 130/143."""

    @pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
    def test_interrupt_long_kernel(self, box, sig, code):
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        with unchanged(box):
            p = subprocess.Popen(
                [sys.executable, "-m", "shbake_cli.main", *LONG_TABLE, "-o", box / "old.h5",
                 "--exr-dir", box / "bands"],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                env=dict(os.environ, NUMBA_NUM_THREADS="1"),
            )  # fmt: skip
            time.sleep(6.0)
            assert p.poll() is None, p.communicate()[1]
            t0 = time.monotonic()
            p.send_signal(sig)
            _, err = p.communicate(timeout=30)
            waited = time.monotonic() - t0
        assert_failed((p.returncode, "", err), code=code, fragment="interrupted")
        assert waited < 10.0, waited  # ~1 s; generous for a loaded machine (not a timing test)

    KERNELS = {  # each runs for minutes uninterrupted; interrupted inside its numba kernel
        "projection-report": ["project-env", "{big}/huge.exr", "-o", "{box}/old.h5", "--lmax", "64",
                              "--report"],
        "probe-fit": ["probe-fit", "{big}/big.exr", "-o", "{box}/old.h5", "--samples", "4096",
                      "--normals", "128"],
        "shrm": ["shrm", "{big}/big.exr", "-o", "{box}/old.h5", "--brdf", "phong", "--F", "48",
                 "--P", "16", "--face-size", "128"],
        "preview-reference": ["preview", "{big}/big.h5", "--pass", "reference", "--size", "1024",
                              "-o", "{box}/old.exr"],
    }  # fmt: skip

    @pytest.mark.parametrize("name", list(KERNELS))
    def test_sigint_in_kernel(self, box, big, name):
        """Exit 130 with one line soon after SIGINT, old outputs byte-identical, no
        temporary: the watcher thread aborts the transaction when the main thread is held
        by a numba kernel (docs/ARCHITECTURE.md, Signals)."""
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        (box / "old.exr").write_bytes((box / "map.exr").read_bytes())
        args = [a.format(big=big, box=box) for a in self.KERNELS[name]]
        with unchanged(box, big):
            p = subprocess.Popen(
                [sys.executable, "-m", "shbake_cli.main", *args],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                env=dict(os.environ, NUMBA_NUM_THREADS="1", SHBAKE_CACHE_DIR="off"),
            )  # fmt: skip
            time.sleep(5.0)
            assert p.poll() is None, p.communicate()[1][-2000:]
            t0 = time.monotonic()
            p.send_signal(signal.SIGINT)
            _, err = p.communicate(timeout=30)
            waited = time.monotonic() - t0
        assert_failed((p.returncode, "", err), code=130, fragment="interrupted")
        assert waited < 10.0, waited  # ~1 s; generous for a loaded machine (not a timing test)

    WATCHED = """
import sys, numba
from shbake_cli.guard import run
from shbake.format import atomic

@numba.njit(nogil=True)  # as shbake.jit.jit compiles every kernel
def spin(n):  # holds the main thread in native code: no Python signal handler can run
    s = 0.0
    for i in range(n):
        s += (i % 7) * 1e-9
    return s

def call():
    with atomic.atomic_path(sys.argv[1]) as tmp:
        with open(tmp, "wb") as f:
            f.write(b"half-written")
        spin(1)
        print("staged", flush=True)
        spin(10**12)
    return 0

sys.exit(run(call, []))
"""

    @pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
    def test_watcher_removes_temporaries_of_a_run_held_in_a_kernel(self, box, sig, code):
        """The main thread is inside a numba loop with an output staged: the watcher thread
        removes the temporary, prints the one line and ends the process; the old output
        stays byte-identical."""
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        with unchanged(box):
            p = subprocess.Popen(
                [sys.executable, "-c", self.WATCHED, str(box / "old.h5")],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            )  # fmt: skip
            try:
                assert p.stdout.readline().strip() == "staged", p.communicate()[1][-2000:]
                assert any(".shbake-" in n for n in os.listdir(box))  # the temporary exists
                time.sleep(0.5)
                p.send_signal(sig)
                _, err = p.communicate(timeout=30)
            finally:
                if p.poll() is None:  # never leave a spinning process behind
                    p.kill()
                    p.wait()
        assert_failed((p.returncode, "", err), code=code, fragment="interrupted")

    CALLBACK = """
import ctypes, os, signal, sys
from shbake_cli.guard import run
from shbake.format import atomic

@ctypes.CFUNCTYPE(None)
def notify():  # as llvmlite's object-cache callback while numba compiles
    os.kill(os.getpid(), signal.SIGINT)  # the handler runs here: its raise cannot leave
    sum(range(1000))

def call():
    with atomic.atomic_path(sys.argv[1]) as tmp:
        with open(tmp, "wb") as f:
            f.write(b"half-written")
        notify()  # called from C: the KeyboardInterrupt is 'ignored' by ctypes
        raise RuntimeError("no compiled object yet")  # what numba raises next
    return 0

sys.exit(run(call, []))
"""

    def test_interrupt_swallowed_by_a_callback(self, box):
        """CI found SIGINT landing in llvmlite's ctypes callback during a numba compile:
        Python printed ``Exception ignored`` and numba's next error became exit 1. The
        interrupt is recorded, so the run ends 130 with one line, no noise, no temporary."""
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        with unchanged(box):
            p = subprocess.run(
                [sys.executable, "-c", self.CALLBACK, str(box / "old.h5")],
                capture_output=True, text=True, timeout=TIMEOUT,
            )  # fmt: skip
        assert_failed((p.returncode, "", p.stderr), code=130, fragment="interrupted")

    def test_other_unraisable_errors_still_print(self):
        """Only a KeyboardInterrupt after a signal is dropped by the unraisable hook."""
        code = ("import gc, sys\nfrom shbake import signals\nsignals.install()\n"
                "class A:\n    def __del__(self):\n        raise ValueError('kept')\n"
                "A()\ngc.collect()\n")  # fmt: skip
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=TIMEOUT)  # fmt: skip
        assert p.returncode == 0 and "Exception ignored" in p.stderr and "kept" in p.stderr

    def test_every_kernel_releases_the_gil(self):
        """The watcher thread needs the GIL while the main thread runs a kernel: every
        kernel is compiled through shbake.jit, whose decorators pass ``nogil=True``."""
        from shbake import jit

        root = Path(jit.__file__).parent
        tokens = ("numba.njit", "@njit", "numba.jit(")
        direct = [str(p) for p in root.rglob("*.py")
                  if p.name != "jit.py" and any(t in p.read_text() for t in tokens)]  # fmt: skip
        assert not direct, direct
        kernel = jit.jit(lambda x: x + 1)
        assert kernel(1) == 2 and kernel.dispatcher.targetoptions.get("nogil") is True

    def test_stale_temporary_removed_live_kept(self, run_cli, box):
        dead = box / f".out.h5.shbake-{dead_pid()}-1.tmp.h5"
        live = box / f".out.h5.shbake-{os.getpid()}-99.tmp.h5"
        other = box / f".other.h5.shbake-{dead_pid()}-1.tmp.h5"
        for p in (dead, live, other):
            p.write_bytes(b"partial")
        code, _, err = run_cli("project-env", box / "map.exr", "-o", box / "out.h5", "-q")
        assert code == 0, err
        assert not dead.exists() and live.exists() and other.exists()


def descendants(pid: int) -> set[int]:
    """Every live descendant process of ``pid`` (Linux ``/proc``)."""
    parents = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            parents[int(entry)] = int(stat.rsplit(")", 1)[1].split()[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parents.items() if pp in frontier} - found
        found |= frontier
    return found


def cmdline(pid: int) -> str:
    """The command line of ``pid`` ("" once it is gone)."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_text(errors="replace")
    except OSError:
        return ""


def alive(pid: int) -> bool:
    """Whether ``pid`` exists and is not a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


class TestPoolWorkers:
    """Item 10: the workers of ``probe-fit --jobs`` die with their parent, however it ends
    (SIGKILL included: the kernel sends them SIGTERM, ``PR_SET_PDEATHSIG``), and leave no
    temporary (each removes its own before exiting)."""

    @pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
    def test_workers_die_with_parent(self, box, big, sig):
        from tests.helpers import write_test_exr

        rng = np.random.default_rng(5)
        maps = []
        for i in range(400):  # ~15 s of fitting on 2 idle cores: the signal lands mid-run
            write_test_exr(box / f"m{i}.exr", 0.5 + rng.random((32, 64, 3)))
            maps.append(box / f"m{i}.exr")
        # the plan cache is shared by both cases (the second loads the plan)
        env = dict(os.environ, NUMBA_NUM_THREADS="1", SHBAKE_CACHE_DIR=str(big / "cache"))
        p = subprocess.Popen(
            [sys.executable, "-m", "shbake_cli.main", "probe-fit", *map(str, maps), "--out-dir",
             str(box / "out"), "--jobs", "2", "-q"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        )  # fmt: skip
        try:
            deadline = time.monotonic() + TIMEOUT
            workers = set()
            while time.monotonic() < deadline and p.poll() is None:
                workers = {c for c in descendants(p.pid) if "spawn_main" in cmdline(c)}
                if len(workers) >= 2:
                    break
                time.sleep(0.2)
            assert len(workers) >= 2 and p.poll() is None, p.communicate()[1][-2000:]
            children = descendants(p.pid)
            time.sleep(1.0)  # the workers are importing or fitting
            p.send_signal(sig)
            _, err = p.communicate(timeout=60)
            end = time.monotonic() + 30
            while time.monotonic() < end and any(alive(c) for c in children):
                time.sleep(0.1)
            assert not [c for c in children if alive(c)], "a worker outlived its parent"
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        if sig == signal.SIGTERM:
            assert_failed((p.returncode, "", err), code=143, fragment="interrupted")
        left = [str(f) for f in box.rglob("*") if ".shbake-" in f.name]
        assert not left, left
        assert not (box / "out").exists() or all(f.suffix == ".h5" for f in (box / "out").iterdir())


# -- 11. determinism --------------------------------------------------------------------------


class TestDeterminism:
    """Item 11: every output type is byte-identical across runs (a second apart: EXR
    ``capDate`` has one-second resolution)."""

    RUNS = {
        "project-env": ["project-env", "{map}", "-o", "{out}/e.h5", "--exr-dir", "{out}/maps",
                        "--png", "--export", "threejs", "--lmax", "4", "-q"],
        "brdf-table": ["brdf-table", "phong", "-o", "{out}/t.h5", "--size", "8", "--lmax", "2",
                       "--samples", "64", "--exr-dir", "{out}/bands", "--reproducible", "-q"],
        "preview": ["preview", "{env}", "-o", "{out}/p.exr", "--size", "8", "--diff", "--png",
                    "-q"],
        "split-sum": ["split-sum", "{map}", "-o", "{out}/s.h5", "--size", "16", "--min-size",
                      "8", "--alphas", "0.25,1", "--samples", "64", "-q"],
    }  # fmt: skip

    @pytest.mark.parametrize("name", list(RUNS))
    def test_identical_bytes(self, run_cli, box, name):
        results = []
        out = box / "out"
        args = [a.format(map=box / "map.exr", env=box / "env.h5", out=out) for a in self.RUNS[name]]
        for i in range(2):  # the same command line (assets record it), a second apart
            out.mkdir()
            code, _, err = run_cli(*args)
            assert code == 0, err
            results.append({str(Path(p).relative_to(out)): b for p, b in snapshot(out).items()})
            out.rename(box / f"run{i}")
            time.sleep(1.1)
        assert results[0].keys() == results[1].keys()
        assert any(k.endswith(".exr") or k.endswith(".h5") for k in results[0])
        differ = [k for k in results[0] if results[0][k] != results[1][k]]
        assert not differ, differ


# -- 12. batches --------------------------------------------------------------------------


class TestBatches:
    """Item 12: a bad map fails the batch (exit 1) without half-written probes; empty set or
    markdown paths are refused (covered in TestOutputLocations)."""

    def test_bad_map_in_batch(self, run_cli, box):
        (box / "bad.exr").write_bytes(b"not an image")
        with unchanged(box):
            assert_failed(run_cli("probe-fit", box / "bad.exr", box / "map.exr", "--out-dir",
                                  box, "--samples", 64))  # fmt: skip

    def test_completed_probes_stay_valid(self, run_cli, box):
        """Per-probe atomic files: the probe fitted before the bad map is complete and valid;
        nothing half-written is left."""
        from shbake.batch.probe_jobs import GATHER_BATCH
        from shbake.format.asset import read_asset

        # one gather pass of good maps, then the bad one in the next pass
        good = []
        for i in range(GATHER_BATCH):
            shutil.copy(box / "map.exr", box / f"m{i}.exr")
            good.append(box / f"m{i}.exr")
        (box / "zbad.exr").write_bytes(b"not an image")
        before = set(os.listdir(box))
        assert_failed(run_cli("probe-fit", *good, box / "zbad.exr", "--out-dir",
                              box / "probes", "--samples", 64))  # fmt: skip
        assert set(os.listdir(box)) == before | {"probes"}
        assert sorted(os.listdir(box / "probes")) == sorted(f"m{i}.h5" for i in range(len(good)))
        for i in range(len(good)):
            assert read_asset(str(box / "probes" / f"m{i}.h5")).kind == "shexp_probe"

    def test_manifest_lists_what_succeeded(self, run_cli, box):
        """``--manifest``: written even when the batch fails; the probes of the completed
        gather pass are ``written`` with their SHA-256, the rest ``not written``."""
        import hashlib
        import json

        from shbake.batch.probe_jobs import GATHER_BATCH

        good = []
        for i in range(GATHER_BATCH):
            shutil.copy(box / "map.exr", box / f"m{i}.exr")
            good.append(box / f"m{i}.exr")
        (box / "zbad.exr").write_bytes(b"not an image")
        manifest = box / "manifest.json"
        assert_failed(run_cli("probe-fit", *good, box / "zbad.exr", "--out-dir", box / "probes",
                              "--samples", 64, "--manifest", manifest))  # fmt: skip
        doc = json.loads(manifest.read_text())
        assert doc["status"].startswith("failed:")
        rows = {os.path.basename(r["source"]): r for r in doc["probes"]}
        assert rows["zbad.exr"]["status"] == "not written"
        for i in range(len(good)):
            row = rows[f"m{i}.exr"]
            assert row["status"] == "written"
            digest = hashlib.sha256((box / "probes" / f"m{i}.h5").read_bytes()).hexdigest()
            assert row["sha256"] == digest

    def test_set_is_all_or_nothing(self, run_cli, box):
        (box / "bad.exr").write_bytes(b"not an image")
        with unchanged(box):
            assert_failed(run_cli("probe-fit", box / "map.exr", box / "bad.exr", "-o",
                                  box / "set.h5", "--samples", 64))  # fmt: skip


# -- minor ------------------------------------------------------------------------------------


class TestMinor:
    """The issue's minor items."""

    def test_8bit_warning_and_colorspace(self, run_cli, box):
        import OpenImageIO as oiio

        img = (np.random.default_rng(0).random((16, 32, 3)) * 255).astype(np.uint8)
        out = oiio.ImageOutput.create(str(box / "ldr.png"))
        out.open(str(box / "ldr.png"), oiio.ImageSpec(32, 16, 3, "uint8"))
        out.write_image(img)
        out.close()
        code, _, err = run_cli("project-env", box / "ldr.png", "-o", box / "a.h5")
        assert code == 0 and "display-referred" in err and "--colorspace" in err
        code, _, err = run_cli("project-env", box / "ldr.png", "-o", box / "b.h5",
                               "--colorspace", "sRGB-display", "--json")  # fmt: skip
        assert code == 0 and "display-referred" not in err

    def test_json_summary_still_one_document(self, run_cli, box):
        code, out, _ = run_cli("project-env", box / "map.exr", "-o", box / "c.h5", "--json")
        assert code == 0
        json.loads(out)

    def test_layout_detection_agrees_with_layout_option(self):
        from shbake.envmap.layouts import LAYOUTS, check_layout, detect_layout
        from shbake.errors import LayoutError

        for h in range(1, 25):
            for w in range(1, 25):
                fitting = []
                for layout in LAYOUTS:
                    with contextlib.suppress(LayoutError):
                        fitting.append(check_layout(layout, h, w))
                try:
                    found = detect_layout(h, w)
                except LayoutError:
                    found = None
                assert (found is None) == (not fitting), (h, w)
                assert found is None or found in fitting, (h, w)

    def test_two_by_one_refused_one_line(self, run_cli, box):
        from tests.helpers import write_test_exr

        write_test_exr(box / "two.exr", np.ones((1, 2, 3)))
        for extra in ([], ["--layout", "latlong"]):
            with unchanged(box):
                assert_failed(run_cli("project-env", box / "two.exr", "-o", box / "t.h5", *extra))
