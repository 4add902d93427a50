"""Issue 27 (Deliver 6, item 14): every command that writes fails cleanly on a full disk,
under a file size limit and on a read-only file system.

For every writing command: a first run (in-process) must succeed in a plain folder, and
gives the blocks and the largest file it writes; the failing runs are subprocesses (a
segfault or teardown noise would show) and must end with exit 1 and exactly one
``shbake: error:`` line, no traceback, every old file byte-identical, no temporary and
no new folder (``bake`` keeps the assets it completed, whole, as ``make`` does, and no
empty folder). The cases:

* a tmpfs with half the blocks the command writes left free: the disk fills up in the
  middle of the run (root: the tests mount it; skipped with the reason otherwise);
* the same filled to the last byte (slow: the first write fails);
* a file size limit of half the largest file (``EFBIG``, any user);
* a read-only tmpfs (root), refused by the checks before any work, and a read-only tmpfs
  whose check is bypassed, so that the writes themselves fail (``EROFS``).

HDF5 assets are built in memory and written with ordinary writes; their bytes are the
file HDF5 writes directly (``TestAssetImage``).
"""

import contextlib
import os
import re
import resource
import shutil
import signal
import subprocess
from pathlib import Path

import h5py
import pytest

from shbake.format import registry
from shbake.format.asset import WRITE_OPTIONS, Asset, write_asset, write_into
from shbake.format.provenance import relativise
from tests.assets_examples import example, write_map
from tests.faults import assert_failed, can_mount, fill, shbake, snapshot, unchanged

SCENE = """[scene]
name = "s"
exports = ["threejs"]
[tolerances]
irradiance = 0.05
[[environments]]
map = "map.exr"
name = "a"
[[materials]]
name = "m"
kind = "diffuse"
"""

SMALL_CUBES = ["--size", "16", "--samples", "16"]

CASES = {
    "project-env": ["project-env", "{in}/map.exr", "-o", "{out}/old.h5", "--exr-dir",
                    "{out}/maps", "--png", "--export", "threejs"],
    "brdf-table": ["brdf-table", "phong", "-o", "{out}/old.h5", "--size", "16", "--lmax", "4",
                   "--samples", "32", "--exr-dir", "{out}/bands"],
    "shrm": ["shrm", "{in}/map.exr", "-o", "{out}/old.h5", "--exr-dir", "{out}/cubes",
             "--face-size", "16"],
    "probe-fit -o": ["probe-fit", "{in}/map.exr", "{in}/other.exr", "-o", "{out}/old.h5"],
    "probe-fit --out-dir": ["probe-fit", "{in}/map.exr", "{in}/other.exr", "--out-dir",
                            "{out}/probes", "--manifest", "{out}/manifest.json"],
    "split-sum": ["split-sum", "{in}/map.exr", "-o", "{out}/old.h5", "--size", "32"],
    "preview": ["preview", "{in}/env.h5", "-o", "{out}/p.exr", "--size", "32", "--png",
                "--diff"],
    "export gltf": ["export", "{in}/env.h5", "--to", "gltf", "-o", "{out}/e.gltf", "--env",
                    "{in}/map.exr", *SMALL_CUBES],
    "export babylon": ["export", "{in}/env.h5", "--to", "babylon", "-o", "{out}/e.gltf",
                       "--env", "{in}/map.exr", *SMALL_CUBES],
    "export threejs": ["export", "{in}/env.h5", "--to", "threejs", "-o", "{out}/e.json"],
    "export unity": ["export", "{in}/env.h5", "--to", "unity", "-o", "{out}/e.json"],
    "export filament": ["export", "{in}/env.h5", "--to", "filament", "-o", "{out}/e_sh.txt",
                        "--env", "{in}/map.exr", *SMALL_CUBES],
    "export ktx2": ["export", "{in}/ss.h5", "--to", "ktx2", "-o", "{out}/e.ktx2", *SMALL_CUBES],
    "probe-eval": ["probe-eval", "{in}/map.exr", "-o", "{out}/r.md", "--size", "8",
                   "--samples", "16", "--roughness", "0.7", "--no-shrm", "--sheet-dir",
                   "{out}/sheets"],
    "plan --emit-make": ["plan", "{out}/scene.toml", "--emit-make", "{out}/scene.mk"],
    "bake": ["bake", "{out}/scene.toml"],
    "tradeoff": ["tradeoff", "env_sh", "--map", "{in}/map.exr", "-o", "{out}/t.png", "--csv",
                 "{out}/t.csv", "--json-file", "{out}/t.json"],
    "overview": ["overview", "{in}/previews", "-o", "{out}/index.html"],
}  # fmt: skip

pytestmark = pytest.mark.xdist_group("full-disk")
"""One worker runs this module (``make test``: ``--dist loadgroup``): :func:`ws` and each
command's :func:`measured` run are made once, not once per worker."""


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """Inputs: two small maps, an env_sh and a splitsum asset, a folder of previews."""
    root = tmp_path_factory.mktemp("disk-inputs")
    write_map(root / "map.exr")
    write_map(root / "other.exr", seed=3)
    assert shbake("project-env", root / "map.exr", "-o", root / "env.h5")[0] == 0
    write_asset(str(root / "ss.h5"), example("splitsum_probe", root / "map.exr"))
    (root / "previews").mkdir()
    status, out, err = shbake("preview", root / "env.h5", "-o", root / "previews" / "p.exr",
                              "--size", 8, "--json")  # fmt: skip
    assert status == 0, err
    (root / "previews" / "p.json").write_text(out)
    return root


def args_of(name: str, ws: Path, out: Path) -> list[str]:
    return [a.format(**{"in": ws, "out": out}) for a in CASES[name]]


def prepare(out: Path, ws: Path) -> None:
    """Old outputs (a valid asset at ``old.h5``) and the scene of ``plan``/``bake``."""
    out.mkdir(exist_ok=True)
    shutil.copy(ws / "env.h5", out / "old.h5")
    shutil.copy(ws / "map.exr", out / "map.exr")
    (out / "scene.toml").write_text(SCENE)


def restore(out: Path, before: dict) -> None:
    """Remove what a run added under ``out`` (files, then folders deepest first)."""
    after = snapshot(out)
    for p in sorted(set(after) - set(before), key=len, reverse=True):
        if after[p] == "dir":
            os.rmdir(p)
        else:
            os.remove(p)


_measured: dict = {}


@pytest.fixture
def measured(ws, tmp_path_factory, run_cli):
    """``name → (blocks, largest file)`` a successful run of the command writes (in-process,
    once per test process); the run must succeed, so no failure below is vacuous."""

    def get(name):
        if name not in _measured:
            out = tmp_path_factory.mktemp("measure")
            prepare(out, ws)
            before = snapshot(out)
            status, _, err = run_cli(*args_of(name, ws, out))
            assert status == 0, err
            after = snapshot(out)
            new = [p for p, v in after.items() if v != "dir" and before.get(p) != v]
            assert new, f"{name} wrote nothing"
            block = os.statvfs(out).f_bsize
            _measured[name] = (sum(-(-os.path.getsize(p) // block) for p in new),
                               max(os.path.getsize(p) for p in new))  # fmt: skip
        return _measured[name]

    return get


@contextlib.contextmanager
def tmpfs(folder: Path, size: str = "16m", read_only: bool = False, setup=None):
    """A tmpfs mounted on ``folder`` (root only: otherwise the test is skipped, saying so);
    ``setup(folder)`` runs before a read-only remount."""
    if not can_mount():
        pytest.skip("needs root on Linux to mount a tmpfs (CI runs as root); the file size "
                    "limit case runs for every user")  # fmt: skip
    folder.mkdir()
    mount = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", folder],
                           capture_output=True, text=True)  # fmt: skip
    if mount.returncode != 0:
        pytest.skip(f"mount -t tmpfs failed: {mount.stderr.strip()}")
    try:
        if setup is not None:
            setup(folder)
        if read_only:
            subprocess.run(["mount", "-o", "remount,ro", folder], check=True)
        yield folder
    finally:
        subprocess.run(["umount", "-l", folder], capture_output=True)


BATCHES = {"bake", "probe-fit --out-dir"}
"""Commands whose completed outputs stay when a later one fails (``docs/FORMAT.md`` §1)."""


def assert_clean_failure(name: str, result, out: Path, before: dict, fragment: str) -> None:
    """One line naming a file it could not write, exit 1; old files byte-identical; no
    temporary, no new folder (batches: completed files may stay, no empty folder)."""
    assert re.search(fragment, assert_failed(result)), result[2]
    after = snapshot(out)
    changed = [p for p in before if after.get(p) != before[p]]
    new = sorted(set(after) - set(before))
    assert not changed, f"changed or removed: {changed}"
    assert not [p for p in new if ".shbake-" in os.path.basename(p)], new
    empty = [p for p in new if after[p] == "dir" and not os.listdir(p)]
    assert not empty, f"empty folders left: {empty}"
    if name not in BATCHES:
        assert not new, f"new: {new}"


def _file_size_limit(nbytes: int):
    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (nbytes, nbytes))

    return limit


class TestEveryWriter:
    """Every command that writes, on a disk that fills up, a file size limit and a read-only
    file system."""

    @pytest.mark.parametrize("name", CASES)
    def test_disk_fills_up(self, name, ws, tmp_path, measured):
        blocks, _ = measured(name)
        with tmpfs(tmp_path / "mnt", setup=lambda d: prepare(d, ws)) as out:
            before = snapshot(out)
            fill(out)
            filler = out / "filler"
            with open(filler, "r+b") as f:  # free half the blocks the command writes
                f.truncate(os.path.getsize(filler) - (blocks // 2) * os.statvfs(out).f_bsize)
            before[str(filler)] = filler.read_bytes()
            assert_clean_failure(name, shbake(*args_of(name, ws, out)), out, before,
                                 "no space left on device writing")  # fmt: skip

    @pytest.mark.slow
    @pytest.mark.parametrize("name", CASES)
    def test_disk_full(self, name, ws, tmp_path, measured):
        measured(name)
        with tmpfs(tmp_path / "mnt", setup=lambda d: prepare(d, ws)) as out:
            fill(out)
            before = snapshot(out)
            assert_clean_failure(name, shbake(*args_of(name, ws, out)), out, before,
                                 "no space left on device writing")  # fmt: skip

    @pytest.mark.parametrize("name", CASES)
    def test_file_size_limit(self, name, ws, tmp_path, measured):
        """Any user: no file may grow past half the largest one the command writes."""
        _, largest = measured(name)
        out = tmp_path / "out"
        prepare(out, ws)
        before = snapshot(out)
        result = shbake(*args_of(name, ws, out), preexec=_file_size_limit(largest // 2))
        assert_clean_failure(name, result, out, before, "writ(e|ing)")

    @pytest.mark.parametrize("name", list(CASES))
    def test_read_only(self, name, ws, tmp_path):
        with tmpfs(tmp_path / "mnt", read_only=True, setup=lambda d: prepare(d, ws)) as out:
            before = snapshot(out)
            assert_clean_failure(name, shbake(*args_of(name, ws, out)), out, before,
                                 "read-only file system")  # fmt: skip

    @pytest.mark.parametrize("name", list(CASES))
    def test_read_only_after_the_checks(self, name, ws, tmp_path, run_cli, monkeypatch):
        """The file system turns read-only after the output checks: the writes fail."""
        from shbake.format import atomic

        monkeypatch.setattr(atomic, "_read_only_fs", lambda folder: False)
        monkeypatch.setattr(os, "access", lambda path, mode, **kw: True)
        with tmpfs(tmp_path / "mnt", read_only=True, setup=lambda d: prepare(d, ws)) as out:
            before = snapshot(out)
            assert_clean_failure(name, run_cli(*args_of(name, ws, out)), out, before,
                                 "read-only file system writing")  # fmt: skip


class TestFolders:
    """Item 14: folders a failed run created are removed (deepest first, if empty)."""

    def test_output_file_and_folder_clash(self, run_cli, ws, tmp_path):
        """``shrm -o x.h5 --exr-dir x.h5`` created the folder ``x.h5`` and left it."""
        with unchanged(tmp_path):
            assert_failed(run_cli("shrm", ws / "map.exr", "-o", tmp_path / "x.h5",
                                  "--exr-dir", tmp_path / "x.h5", "--face-size", 16),
                          fragment="cannot also be an output folder")  # fmt: skip

    @pytest.mark.parametrize("command", ["project-env", "brdf-table"])
    def test_clash_other_companion_writers(self, run_cli, ws, tmp_path, command):
        args = {"project-env": ["project-env", ws / "map.exr"],
                "brdf-table": ["brdf-table", "phong", "--size", 8, "--lmax", 2,
                               "--samples", 16]}[command]  # fmt: skip
        with unchanged(tmp_path):
            assert_failed(run_cli(*args, "-o", tmp_path / "x.h5", "--exr-dir", tmp_path / "x.h5"),
                          fragment="cannot also be an output folder")  # fmt: skip

    def test_nested_folders_removed(self, run_cli, ws, tmp_path):
        """Three folders created for the maps, removed when a map overflows half floats."""
        write_map(tmp_path / "bright.exr", scale=1e6)
        with unchanged(tmp_path):
            assert_failed(run_cli("project-env", tmp_path / "bright.exr", "-o",
                                  tmp_path / "old.h5", "--exr-dir", tmp_path / "a" / "b" / "c"),
                          fragment="half")  # fmt: skip

    def test_sheet_dir_of_a_failed_probe_eval(self, run_cli, ws, tmp_path, monkeypatch):
        """The report fails after the sheets were staged: their folders go too."""
        import errno

        import shbake_cli.probe_eval

        def full(path, text):
            raise OSError(errno.ENOSPC, "No space left on device", str(path))

        monkeypatch.setattr(shbake_cli.probe_eval, "write_text", full)
        with unchanged(tmp_path):
            assert_failed(run_cli("probe-eval", ws / "map.exr", "-o", tmp_path / "r.md",
                                  "--size", 8, "--samples", 16, "--roughness", 0.7, "--no-shrm",
                                  "--sheet-dir", tmp_path / "s" / "t"),
                          fragment="no space left on device")  # fmt: skip


class TestAssetImage:
    """The in-memory HDF5 image is the file HDF5 writes directly (the writer before issue
    27): same bytes for every kind."""

    @pytest.mark.parametrize("kind", list(registry.kinds()))
    def test_same_bytes_as_a_direct_write(self, kind, ws, tmp_path):
        asset = example(kind, ws / "map.exr")
        image, direct = tmp_path / "image.h5", tmp_path / "direct.h5"
        write_asset(str(image), asset)
        attrs = relativise(asset.attrs, str(direct))
        with h5py.File(direct, "w", **WRITE_OPTIONS) as f:
            write_into(f, Asset(asset.kind, attrs, asset.datasets, asset.dataset_attrs))
        assert image.read_bytes() == direct.read_bytes()


class TestImages:
    """OpenImageIO's PNG writer reports success when the write it makes at ``close`` fails;
    so does OpenEXR's buffered stream (a file size limit cut a 390-byte map at 128 bytes,
    reported written). Each written file's layout is read back
    (:func:`shbake.format.images.check_png`, :func:`~shbake.format.images.check_exr`)."""

    SCRIPT = """
import resource, signal, sys
import numpy as np
from shbake.format.images import write_exr, write_png
limit, kind = int(sys.argv[2]), sys.argv[3]
if limit:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
rng = np.random.default_rng(0)
if kind.startswith("png"):
    write_png(sys.argv[1], (rng.random((64, 64, int(kind[3:]))) * 255).astype(np.uint8))
else:
    write_exr(sys.argv[1], rng.random((40, 24, 3)), half=kind == "exr-half")
"""

    @pytest.mark.parametrize("kind", ["png3", "png4", "exr-half", "exr-float"])
    def test_short_by_one_byte(self, tmp_path, kind):
        import sys

        def run(path, limit):
            return subprocess.run([sys.executable, "-c", self.SCRIPT, path, str(limit), kind],
                                  capture_output=True, text=True)  # fmt: skip

        suffix = "." + kind[:3]
        whole = tmp_path / f"whole{suffix}"
        assert run(whole, 0).returncode == 0
        size = whole.stat().st_size
        with unchanged(tmp_path):
            short = run(tmp_path / f"short{suffix}", size - 1)
        assert short.returncode == 1 and "cannot write all of" in short.stderr, short.stderr

    @pytest.mark.parametrize("shape", [(1, 1, 3), (17, 9, 1), (20, 3, 4)])
    @pytest.mark.parametrize("half", [True, False])
    def test_every_cut_refused_every_whole_file_kept(self, tmp_path, shape, half):
        """Whole files OpenImageIO wrote (one or two chunks, 1 to 4 channels, half and float)
        pass; the same files cut at every length, or with a byte appended, are refused."""
        import numpy as np

        from shbake.errors import OutputError
        from shbake.format.images import check_exr, write_exr

        path = tmp_path / "x.exr"
        write_exr(str(path), np.random.default_rng(1).random(shape), half=half,
                  channel_names=("Y", "G", "B", "A")[: shape[2]] if shape[2] != 3 else None)
        check_exr(str(path), "x.exr")
        data = path.read_bytes()
        for cut in [*range(len(data)), len(data) + 1]:
            path.write_bytes(data[:cut] if cut < len(data) else data + b"\0")
            with pytest.raises(OutputError, match="cannot write all of x.exr"):
                check_exr(str(path), "x.exr")


class TestCostCalibration:
    """``plan`` measures each recipe's fixed cost once per machine by baking a tiny scene in a
    temporary folder (:func:`shbake.batch.plan_costs.measure_overheads`)."""

    SCRIPT = """
import resource, signal, sys
from shbake.batch.plan_costs import measure_overheads
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (128, 128))  # below the map's header
try:
    measure_overheads(["env_sh"])
except Exception as e:
    print(type(e).__name__, e)
"""

    def test_its_map_unwritten_says_so(self, tmp_path):
        """The tiny map cannot be written (a file size limit): the error names that write,
        not the recipe that then read a truncated map ("truncated or corrupt image"), and
        its temporary folder is removed."""
        import sys

        env = dict(os.environ, TMPDIR=str(tmp_path))
        done = subprocess.run([sys.executable, "-c", self.SCRIPT], capture_output=True,
                              text=True, env=env, timeout=120)  # fmt: skip
        assert re.fullmatch(r"OutputError cannot write all of \S+/shbake-costs-\w+/tiny\.exr "
                            r"\(a disk quota, a file size limit or an I/O error\)\n",
                            done.stdout), done.stdout + done.stderr  # fmt: skip
        assert os.listdir(tmp_path) == []
