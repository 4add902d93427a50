"""Issue 27, items 6-7: Dask schedulers are checked before any work and stop cleanly.

``--scheduler`` is parsed before anything else (a malformed address is a usage error,
exit 2) and connected before any planning (nothing listening: one line, exit 1). The
workers of a 2-worker ``LocalCluster`` on 127.0.0.1 (processes, started here) write
nothing where outputs go: they return their outputs' bytes and the client writes them in
its own transaction, so an interrupted ``bake --scheduler`` leaves the out_dir exactly as
it was, at exit and once the workers have finished the tasks it left running
(docs/SCENES.md, Dask).
"""

import hashlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from shbake.batch import scheduler
from shbake.errors import InputError, ParameterError
from shbake.format import atomic
from tests.faults import TIMEOUT, assert_failed, shbake, snapshot, unchanged
from tests.helpers import local_cluster, write_test_exr


@pytest.fixture(scope="module")
def cluster():
    with local_cluster() as address:
        yield address


def nothing_listens() -> str:
    """An address on 127.0.0.1 where nothing listens (a port just released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"127.0.0.1:{port}"


SCENE = """[scene]
name = "many"
exports = ["threejs"]
[[environments]]
map = "maps/{maps}"
[[materials]]
name = "plaster"
kind = "diffuse"
[[materials]]
name = "chrome"
kind = "glossy"
roughness = [0.05, 0.15]
"""
"""A scene with an env_sh, a split-sum and a three.js export per map."""


def write_scene(folder: Path, n_maps: int, maps: str = "*.exr") -> Path:
    """``folder/scene.toml`` over ``n_maps`` random 64x128 maps (written once)."""
    (folder / "maps").mkdir(exist_ok=True)
    rng = np.random.default_rng(3)
    for i in range(n_maps):
        path = folder / "maps" / f"m{i:02d}.exr"
        if not path.exists():
            write_test_exr(path, 0.2 + rng.random((64, 128, 3)))
    scene = folder / "scene.toml"
    scene.write_text(SCENE.format(maps=maps))
    return scene


def idle(address: str) -> bool:
    """Wait until the scheduler at ``address`` holds no task and no worker holds one: the
    tasks of a client that has gone finish on their worker (Dask cannot stop them), then
    are forgotten. ``False`` after :data:`TIMEOUT` seconds."""
    from distributed import Client

    with Client(address, set_as_default=False) as client:
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            held = client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))
            held += sum(client.run(lambda dask_worker: len(dask_worker.state.tasks)).values())
            if not held:
                return True
            time.sleep(0.1)
    return False


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


class TestAddress:
    @pytest.mark.parametrize("text, address", [
        ("127.0.0.1:8786", "tcp://127.0.0.1:8786"),
        ("tcp://sched-1.farm.example:8786", "tcp://sched-1.farm.example:8786"),
        ("tls://[::1]:65535", "tls://[::1]:65535"),
        ("ws://localhost:1", "ws://localhost:1"),
    ])  # fmt: skip
    def test_accepted(self, text, address):
        assert scheduler.parse_address(text) == address

    MALFORMED = ["zzz://nope", "garbage", "", "tcp://127.0.0.1:8786;touch INJECTED",
                 "$(touch INJECTED):8786", "127.0.0.1:87\x1b]0;title\x07", "tcp://a b:8786",
                 "tcp://127.0.0.1:0", "tcp://127.0.0.1:65536", "127.0.0.1:8786\n",
                 "inproc://127.0.0.1:8786", "tcp://été.example:8786", "tcp://h:８７８６",
                 "h" * 400 + ":8786"]  # fmt: skip

    @pytest.mark.parametrize("text", MALFORMED)
    def test_refused(self, text):
        with pytest.raises(ParameterError, match="is not a Dask scheduler address"):
            scheduler.parse_address(text)

    @pytest.mark.parametrize("command", ["bake", "probe-fit"])
    @pytest.mark.parametrize("text", ["zzz://nope", "garbage", "127.0.0.1:87\x1b]0;title\x07",
                                      "tcp://127.0.0.1:8786;touch INJECTED"])  # fmt: skip
    def test_malformed_is_a_usage_error(self, run_cli, tmp_path, command, text):
        """One line, exit 2, the control characters escaped, nothing written; before the
        scene or the maps are even read."""
        scene = write_scene(tmp_path, 1)
        args = [scene] if command == "bake" else [tmp_path / "maps" / "m00.exr", "--out-dir",
                                                  tmp_path / "probes"]  # fmt: skip
        with unchanged(tmp_path):
            code, out, err = run_cli(command, *args, "--scheduler", text)
        line = assert_failed((code, out, err), code=2, fragment="--scheduler")
        assert "is not a Dask scheduler address" in line
        assert "\x1b" not in err and "\x07" not in err and out == ""

    @pytest.mark.parametrize("command, extra", [("bake", ["--jobs", "2"]),
                                                ("bake", ["--asset", "env_sh/m00"]),
                                                ("probe-fit", ["--jobs", "2"])])  # fmt: skip
    def test_scheduler_with_local_workers_is_a_usage_error(self, run_cli, tmp_path, command,
                                                           extra):  # fmt: skip
        scene = write_scene(tmp_path, 1)
        args = [scene] if command == "bake" else [tmp_path / "maps" / "m00.exr", "--out-dir",
                                                  tmp_path / "probes"]  # fmt: skip
        with unchanged(tmp_path):
            result = run_cli(command, *args, *extra, "--scheduler", nothing_listens())
        assert_failed(result, code=2, fragment="--scheduler")


class TestConnectBeforePlanning:
    @pytest.mark.parametrize("command", ["bake", "probe-fit"])
    def test_unreachable_is_one_line_and_nothing_is_planned(self, run_cli, tmp_path,
                                                            monkeypatch, command):  # fmt: skip
        """Nothing listens: one line naming the address, exit 1, and the planner (bake) or
        the job list and settings study (probe-fit) never ran: the connection comes first."""
        from shbake.batch import probe_fit, scene_bake

        def never(*args, **kwargs):
            raise AssertionError("planned before connecting")

        monkeypatch.setattr(scene_bake, "plan_scene_kept", never)
        monkeypatch.setattr(probe_fit, "make_jobs", never)
        scene = write_scene(tmp_path, 1)
        address = nothing_listens()
        args = [scene] if command == "bake" else [tmp_path / "maps" / "m00.exr", "--out-dir",
                                                  tmp_path / "probes", "--tol", "0.1"]  # fmt: skip
        with unchanged(tmp_path):
            result = run_cli(command, *args, "--scheduler", address, "--connect-timeout", "1")
        line = assert_failed(result, code=1, fragment="cannot reach the Dask scheduler")
        assert f"tcp://{address}" in line and "within 1 s" in line

    def test_unreachable_command_line(self, tmp_path):
        """The real command: exit 1, exactly one line on stderr and nothing on stdout
        (was 48-58 lines of tracebacks), within the connect timeout, nothing written."""
        scene = write_scene(tmp_path, 1)
        with unchanged(tmp_path):
            code, out, err = shbake("bake", scene, "--scheduler", nothing_listens())
        assert_failed((code, out, err), code=1, fragment="cannot reach the Dask scheduler")
        assert err.count("\n") == 1 and out == ""


def command_args(command: str, folder: Path) -> list:
    """The inputs of a run of ``command`` (``bake`` or ``probe-fit``) on one map in
    ``folder``."""
    scene = write_scene(folder, 1)
    return [scene] if command == "bake" else [folder / "maps" / "m00.exr", "--out-dir",
                                              folder / "probes"]  # fmt: skip


class TestConnectTimeout:
    """``--connect-timeout SECONDS`` (``connect(address, timeout)`` in the library): how long
    connecting may take, named in the one line of an unreachable scheduler."""

    COMMANDS = ["bake", "probe-fit"]
    """The commands that take ``--scheduler``."""

    @pytest.mark.parametrize("command", COMMANDS)
    def test_unreachable_command_line(self, tmp_path, command):
        """The real command: exit 1, one line naming the timeout given, nothing on stdout,
        nothing written."""
        args = command_args(command, tmp_path)
        with unchanged(tmp_path):
            code, out, err = shbake(command, *args, "--scheduler", nothing_listens(),
                                    "--connect-timeout", "0.5")  # fmt: skip
        line = assert_failed((code, out, err), code=1, fragment="cannot reach the Dask scheduler")
        assert "within 0.5 s (" in line and "within 10 s" not in line
        assert err.count("\n") == 1 and out == ""

    def test_library_connect(self):
        """``connect(address, timeout=0.5)`` gives up after about 0.5 s (well before the
        default 10 s, a bound that holds on a loaded machine) and says so."""
        address = nothing_listens()
        t0 = time.monotonic()
        with pytest.raises(InputError) as e:
            scheduler.connect(address, timeout=0.5)
        seconds = time.monotonic() - t0
        assert str(e.value).startswith(f"cannot reach the Dask scheduler at tcp://{address} "
                                       "within 0.5 s (")  # fmt: skip
        assert seconds < 8, seconds

    def test_default_is_named(self, monkeypatch):
        """Without a timeout, the line names :data:`CONNECT_SECONDS` (no 10 s wait here:
        the comm is refused at once)."""

        def refused(address, timeout):
            assert timeout == scheduler.CONNECT_SECONDS == 10
            raise ConnectionRefusedError(111, "Connection refused")

        monkeypatch.setattr(scheduler, "_reach", refused)
        with pytest.raises(InputError, match=r"within 10 s \(Connection refused\)"):
            scheduler.connect(nothing_listens())

    def test_library_entry_points_take_it(self, tmp_path):
        """``bake_scene``, ``fit_probes`` and ``run_dask`` pass ``connect_timeout`` on."""
        from shbake.bakers.shexp import FitConfig
        from shbake.batch.probe_fit import fit_probes
        from shbake.batch.probe_jobs import ProbeJob, run_dask
        from shbake.batch.scene import load_scene
        from shbake.batch.scene_bake import bake_scene

        scene = write_scene(tmp_path, 1)
        map_path = str(tmp_path / "maps" / "m00.exr")
        job = ProbeJob(map_path, str(tmp_path / "p.h5"), FitConfig(normals=16, views=8,
                                                                   samples=64))  # fmt: skip
        runs = [lambda a: bake_scene(load_scene(str(scene)), scheduler=a, connect_timeout=0.5),
                lambda a: fit_probes([map_path], out_dir=str(tmp_path / "probes"),
                                     scheduler=a, connect_timeout=0.5),
                lambda a: run_dask([job], a, connect_timeout=0.5)]  # fmt: skip
        for run in runs:
            with unchanged(tmp_path), pytest.raises(InputError, match=r"within 0\.5 s \("):
                run(nothing_listens())

    @pytest.mark.parametrize("value", [0, -1, float("nan"), float("inf"), -float("inf"), 601,
                                       "soon", None])  # fmt: skip
    def test_library_refuses(self, monkeypatch, value):
        """A timeout that is not a finite number of seconds in (0, 600] is refused before
        any connection is tried."""

        def never(*args, **kwargs):
            raise AssertionError("connected with a bad timeout")

        monkeypatch.setattr(scheduler, "_reach", never)
        with pytest.raises(ParameterError, match=r"expected seconds in \(0, 600\]"):
            scheduler.connect(nothing_listens(), timeout=value)

    @pytest.mark.parametrize("command", COMMANDS)
    @pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "-inf", "601", "1e300", "x"])
    def test_bad_value_is_a_usage_error(self, run_cli, tmp_path, command, value):
        args = command_args(command, tmp_path)
        with unchanged(tmp_path):
            code, out, err = run_cli(command, *args, "--scheduler", nothing_listens(),
                                     "--connect-timeout", value)  # fmt: skip
        line = assert_failed((code, out, err), code=2, fragment="--connect-timeout")
        assert "Invalid value for '--connect-timeout'" in line and out == ""

    @pytest.mark.parametrize("command", COMMANDS)
    def test_without_scheduler_is_a_usage_error(self, run_cli, tmp_path, command):
        """Like ``--tol`` without ``--lights auto``: refused, not ignored."""
        args = command_args(command, tmp_path)
        with unchanged(tmp_path):
            result = run_cli(command, *args, "--connect-timeout", "5")
        line = assert_failed(result, code=2, fragment="--connect-timeout")
        assert line == "shbake: error: --connect-timeout applies to --scheduler only"

    @pytest.mark.parametrize("command", COMMANDS)
    def test_help(self, run_cli, command):
        code, out, _ = run_cli(command, "--help")
        out = " ".join(out.split())  # as wrapped at any width
        assert code == 0 and "--scheduler ADDRESS" in out
        assert "--connect-timeout SECONDS" in out and "[default: 10.0;" in out


class TestCollected:
    """``atomic.collected``: what a Dask task writes is staged in its own scratch folder."""

    def test_outputs_collected_nothing_beside_targets(self, tmp_path):
        target = tmp_path / "sub" / "a.txt"
        with atomic.collected() as outputs:
            with atomic.detached(), atomic.transaction():  # as each baker commits its asset
                atomic.makedirs(target.parent)
                atomic.write_text(str(target), "bytes")
            assert atomic.staged(str(target)) is not None  # read back by later steps
            assert outputs.read(str(target)) == b"bytes"
            scratch = outputs.folder
            assert os.listdir(tmp_path) == []  # no target, temporary or folder
        assert not os.path.exists(scratch)
        assert os.listdir(tmp_path) == []

    def test_threads_keep_their_own_transactions(self, tmp_path):
        """A Dask worker runs tasks in threads: each thread's transaction is its own."""
        both_inside = threading.Barrier(2)
        seen = {}

        def task(name):
            with atomic.transaction() as t:
                atomic.write_text(str(tmp_path / name), name)
                both_inside.wait(timeout=30)
                seen[name] = (t, atomic.active(), list(t.staged))

        threads = [threading.Thread(target=task, args=(n,)) for n in ("a", "b")]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        assert seen["a"][0] is not seen["b"][0]
        for name, (t, active, staged) in seen.items():
            assert active is t and staged == [str(tmp_path / name)]
            assert (tmp_path / name).read_text() == name


class TestWorkersWriteNothing:
    """A task returns its outputs' bytes; the worker writes nothing where outputs go, so a
    task that finishes after the client has gone leaves no file."""

    def test_bake_task(self, cluster, tmp_path):
        from distributed import Client

        from shbake.batch.plan import plan_scene
        from shbake.batch.scene import load_scene
        from shbake.batch.scene_bake import _dask_bake, bake_scene

        scene = load_scene(str(write_scene(tmp_path, 1)))
        asset = next(a for a in plan_scene(scene)["assets"] if a["kind"] == "splitsum")
        folder = Path(asset["output"]).parent
        folder.mkdir(parents=True)  # the client creates the asset's folder before submitting
        with Client(cluster, set_as_default=False) as client:
            [(record, files)] = client.submit(_dask_bake, [asset], {}, pure=False).result()
        assert list(folder.iterdir()) == []  # no output, no temporary
        name = Path(asset["output"]).name
        assert list(files) == [name] == list(record["outputs"])
        assert hashlib.sha256(files[name]).hexdigest() == record["outputs"][name]
        bake_scene(scene)  # here, in one process
        assert Path(asset["output"]).read_bytes() == files[name]

    def test_probe_task(self, cluster, tmp_path):
        from distributed import Client

        from shbake.bakers.shexp import FitConfig
        from shbake.batch.probe_jobs import ProbeJob, _dask_job, run_local

        write_scene(tmp_path, 1)
        config = FitConfig(normals=16, views=8, samples=64)
        job = ProbeJob(str(tmp_path / "maps" / "m00.exr"), str(tmp_path / "p.h5"), config)
        with Client(cluster, set_as_default=False) as client:
            summary, data = client.submit(_dask_job, job, pure=False).result()
        assert sorted(os.listdir(tmp_path)) == ["maps", "scene.toml"]
        assert summary["output"] == job.output
        run_local([job])
        assert Path(job.output).read_bytes() == data


class TestInterrupt:
    @pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
    def test_interrupted_bake_leaves_the_out_dir_as_it_was(self, cluster, tmp_path, sig, code):
        """Exit 130/143 and one line; the out_dir (lock, assets, stamps) byte-identical to
        before the run, no temporary, at exit and once the workers' tasks still running then
        have finished (into their own scratch folders); the lock matches the files."""
        from shbake.batch.scene import load_scene
        from shbake.batch.scene_bake import bake_scene

        write_scene(tmp_path, 12, maps="m00.exr")
        bake_scene(load_scene(str(tmp_path / "scene.toml")))  # old outputs and their lock
        scene = write_scene(tmp_path, 12)  # now every map: 36 assets to bake
        out = tmp_path / "scene-assets"
        before = snapshot(out)
        assert len([p for p in before if p.endswith(".h5")]) == 2  # env_sh/m00, splitsum/m00
        p = subprocess.Popen(
            [sys.executable, "-m", "shbake_cli.main", "bake", str(scene), "--scheduler", cluster],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env=dict(os.environ, NUMBA_NUM_THREADS="1"),
        )  # fmt: skip
        try:
            deadline = time.monotonic() + TIMEOUT
            while time.monotonic() < deadline and p.poll() is None:
                if any(atomic.TAG in f.name for f in out.rglob("*")):
                    break  # the client is writing what the first tasks returned
                time.sleep(0.02)
            assert p.poll() is None, p.communicate()[1][-2000:]
            p.send_signal(sig)
            _, err = p.communicate(timeout=60)
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        assert_failed((p.returncode, "", err), code=code, fragment="interrupted")
        assert err == "shbake: error: interrupted\n"
        at_exit = snapshot(out)
        assert idle(cluster), "the workers' tasks did not finish"
        assert snapshot(out) == at_exit == before
        lock = json.loads((out / "scene.lock.json").read_text())
        hashes = {f: sha256(f) for f in out.rglob("*") if f.is_file()}
        for record in lock["assets"].values():
            for rel, digest in record["outputs"].items():
                assert any(str(f).endswith("/" + rel) and h == digest for f, h in hashes.items())
