"""Signals (issue 11, item 10): SIGINT and SIGTERM stop a run within about a second anywhere,
native kernels and numba's compiler included, clean up and exit 130/143; the workers of
``probe-fit --jobs`` die with their parent however it ends and leave no temporary.
"""

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from tests.faults import TIMEOUT, assert_failed, computing, dead_pid, unchanged

LONG_TABLE = ["brdf-table", "phong", "--size", "512", "--lmax", "8", "--samples", "262144"]
"""One kernel call of this table (a 16th of its views, ``ADVANCE_STEPS``, per rule) runs
well over a minute (watcher off: still running 12 s after the signal, 2-core machine)."""
PROBE_FIT = ["probe-fit", "{big}/big.exr", "-o", "{box}/old.h5", "--samples", "16384",
             "--normals", "128"]  # fmt: skip
"""Its targets' plan is one kernel call of over a minute (watcher off: still running 12 s
after the signal, 3 runs of 3)."""
WATCHER_LIMIT = 10.0
"""Seconds a run held in a kernel may take to end after the signal: the watcher's
``GRACE_SECONDS`` (1 s) and a loaded machine's delays, far below the kernel calls above,
so that only the watcher ends the run in time (Python's own handler waits for the call)."""


def interrupt(p: subprocess.Popen, sig: int) -> str:
    """Send ``sig`` to ``p``, which computes inside one long kernel call; its stderr once it
    ends. Fails (and kills it) if it has not ended within :data:`WATCHER_LIMIT`."""
    p.send_signal(sig)
    try:
        return p.communicate(timeout=WATCHER_LIMIT)[1]
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
        pytest.fail(f"still running {WATCHER_LIMIT} s after the signal: no watcher stopped it")


def sigint_while_computing(box, big, template: list[str]) -> None:
    """Run ``shbake`` with ``template`` (``{box}``, ``{big}`` filled in), SIGINT once it
    computes (:func:`interrupt`): exit 130 with one line, ``box`` and ``big`` unchanged."""
    args = [a.format(big=big, box=box) for a in template]
    with unchanged(box, big):
        p = subprocess.Popen(
            [sys.executable, "-m", "shbake_cli.main", *args],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env=dict(os.environ, NUMBA_NUM_THREADS="1", SHBAKE_CACHE_DIR="off"),
        )  # fmt: skip
        assert computing(p), p.communicate()[1][-2000:]
        err = interrupt(p, signal.SIGINT)
    assert_failed((p.returncode, "", err), code=130, fragment="interrupted")


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
        """Exit 130/143 with one line soon after the signal, the old output byte-identical,
        no temporary: the signal lands while brdf-table tabulates in a kernel call of over a
        minute, so only the watcher thread can end the run in time (docs/ARCHITECTURE.md,
        Signals)."""
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        with unchanged(box):
            p = subprocess.Popen(
                [sys.executable, "-m", "shbake_cli.main", *LONG_TABLE, "-o", box / "old.h5",
                 "--exr-dir", box / "bands"],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                env=dict(os.environ, NUMBA_NUM_THREADS="1"),
            )  # fmt: skip
            assert computing(p), p.communicate()[1][-2000:]
            err = interrupt(p, sig)
        assert_failed((p.returncode, "", err), code=code, fragment="interrupted")

    def test_sigint_in_kernel(self, box, big):
        """Exit 130 with one line soon after SIGINT, the old output byte-identical, no
        temporary: probe-fit is held in a kernel call of over a minute, so only the watcher
        thread can abort the transaction in time (docs/ARCHITECTURE.md, Signals). The
        watcher's work does not depend on the command (it aborts every open transaction):
        this, :meth:`test_interrupt_long_kernel` (brdf-table, SIGINT and SIGTERM) and
        :meth:`test_watcher_removes_temporaries_of_a_run_held_in_a_kernel` prove it for every
        kernel; project-env --report, shrm and preview's reference return to Python every
        few seconds at most (:meth:`test_sigint_mid_run`)."""
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        sigint_while_computing(box, big, PROBE_FIT)

    MID_RUN = {  # kernels that hand back to Python every few seconds at most
        "projection-report": ["project-env", "{big}/huge.exr", "-o", "{box}/old.h5", "--lmax", "64",
                              "--report"],
        "shrm": ["shrm", "{big}/big.exr", "-o", "{box}/old.h5", "--brdf", "phong", "--F", "48",
                 "--P", "16", "--face-size", "128"],
        "preview-reference": ["preview", "{big}/big.h5", "--pass", "reference", "--size", "1024",
                              "-o", "{box}/old.exr"],
    }  # fmt: skip

    @pytest.mark.parametrize("name", list(MID_RUN))
    def test_sigint_mid_run(self, box, big, name):
        """Exit 130 with one line after SIGINT, old outputs byte-identical, no temporary:
        the signal lands while the command computes (its kernels return to Python between
        blocks, where the interrupt may be Python's own or the watcher's; the watcher alone
        is proven by :meth:`test_sigint_in_kernel`)."""
        (box / "old.h5").write_bytes((box / "env.h5").read_bytes())
        (box / "old.exr").write_bytes((box / "map.exr").read_bytes())
        sigint_while_computing(box, big, self.MID_RUN[name])

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
                assert computing(p, cpu_seconds=0.2), p.communicate()[1][-2000:]
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

    COMMIT = """
import os, signal, sys
from shbake import signals
from shbake.format import atomic
signals.install()
replace = os.replace
def replace_then_signal(src, dst):  # the signal lands between two renames of the commit
    replace(src, dst)
    os.kill(os.getpid(), signal.SIGINT)
os.replace = replace_then_signal
try:
    with atomic.transaction():
        for name in sys.argv[1:]:
            with atomic.atomic_path(name) as tmp, open(tmp, "w") as f:
                f.write("new")
except KeyboardInterrupt:
    sys.exit(130)
sys.exit(0)
"""

    def test_signal_during_commit_moves_all_or_none(self, box):
        """A signal between two renames of a commit does not leave a mix of two runs: the
        commit ends, then the interrupt is raised (exit 130, every output new)."""
        names = [box / f"out{i}.txt" for i in range(3)]
        for n in names:
            n.write_text("old")
        p = subprocess.run([sys.executable, "-c", self.COMMIT, *map(str, names)],
                           capture_output=True, text=True, timeout=TIMEOUT)  # fmt: skip
        assert p.returncode == 130, p.stderr
        assert [n.read_text() for n in names] == ["new"] * 3
        assert not [f for f in os.listdir(box) if ".tmp" in f]

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
    (SIGKILL included: the fork server they were forked from exits with it and the kernel
    then sends them SIGTERM, ``PR_SET_PDEATHSIG``), and leave no
    temporary (each removes its own before exiting)."""

    @pytest.fixture
    def short_tmp(self):
        """A ``$TMPDIR`` short enough for the fork server's socket path (pytest's are not
        always: it then goes in ``/tmp``)."""
        folder = tempfile.mkdtemp(prefix="t", dir="/tmp")
        yield folder
        shutil.rmtree(folder)

    def test_fork_server_ignores_ctrl_c_while_it_warms(self):
        """Ctrl-C reaches the fork server while it imports the warm modules (before
        multiprocessing ignores SIGINT there): the import goes on, no traceback."""
        code = ("import os, signal\nimport shbake.jit as jit\nload = jit.load_numba\n"
                "def interrupted():\n    os.kill(os.getpid(), signal.SIGINT)\n    load()\n"
                "jit.load_numba = interrupted\nimport shbake.batch.warm_worker\nprint('warm')\n")
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=TIMEOUT)  # fmt: skip
        assert (p.returncode, p.stdout, p.stderr) == (0, "warm\n", "")

    def test_ctrl_c_while_the_fork_server_stops(self, box):
        """A Ctrl-C after the run, while its fork server stops: the teardown finishes (no
        traceback, exit 0: every output was written)."""
        code = ("import os, signal, sys\nimport shbake.batch.workers as w\nstop = w.stop_server\n"
                "def interrupted():\n    os.kill(os.getpid(), signal.SIGINT)\n    stop()\n"
                "w.stop_server = interrupted\nfrom shbake_cli.main import main\n"
                "sys.argv = ['shbake', *sys.argv[1:]]\nmain()\n")
        args = ["probe-fit", box / "map.exr", "--out-dir", box / "od", "-q", "--jobs", "2",
                "--normals", "8", "--views", "4", "--samples", "16"]  # fmt: skip
        p = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                           text=True, timeout=TIMEOUT)  # fmt: skip
        assert (p.returncode, p.stderr) == (0, "")
        assert os.listdir(box / "od") == ["map.h5"]

    def test_no_folder_left_in_tmpdir(self, box, short_tmp):
        """The fork server's socket lives in a ``pymp-*`` folder of ``$TMPDIR``
        (:mod:`shbake.batch.workers`): removed when the command ends (it was left by every
        ``--jobs`` run, the CLI ending with ``os._exit``)."""
        from shbake.batch.project_many import TASK_MAPS
        from tests.helpers import write_test_exr

        rng = np.random.default_rng(6)
        maps = [box / f"m{i}.exr" for i in range(2 * TASK_MAPS)]  # two tasks: a pool
        for path in maps:
            write_test_exr(path, 0.5 + rng.random((16, 32, 3)))
        long = box / ("x" * 80)  # too long a folder for a socket: it goes in /tmp
        long.mkdir()
        for tmp in (short_tmp, long):
            out = box / f"out-{len(str(tmp))}"
            done = subprocess.run(
                [sys.executable, "-m", "shbake_cli.main", "project-env", *map(str, maps),
                 "--out-dir", str(out), "--jobs", "2", "-q"],
                capture_output=True, text=True, env=dict(os.environ, TMPDIR=str(tmp)),
            )  # fmt: skip
            assert done.returncode == 0, done.stderr[-2000:]
            assert len(list(out.iterdir())) == len(maps)
            assert os.listdir(tmp) == []

    def test_workers_killed_after_the_map_was_left(self, monkeypatch):
        """SIGTERM raised while the command waits for a result leaves ``pool.map``; its
        workers die too (a signal to the process group). The pool's manager thread fails
        the jobs left, with no error of its own: CPython 3.11's ``map`` cancelled them in
        the command's thread, and the manager's ``set_exception`` on a cancelled job raised
        ``InvalidStateError``, a traceback on the command's stderr (CI, ``SIGTERM`` case of
        :meth:`test_workers_die_with_parent`)."""
        import multiprocessing.forkserver
        import threading

        from shbake.batch.workers import worker_pool

        errors = []
        monkeypatch.setattr(threading, "excepthook", errors.append)
        before = set(threading.enumerate())
        with pytest.raises(KeyboardInterrupt), worker_pool(2) as pool:
            # one short job, then long ones: once the first result is in, the manager
            # thread has queued what the workers can take and waits (no job ends), the
            # rest are pending
            results = pool.map(time.sleep, [0.1] + [60] * 11)
            next(results)
            time.sleep(0.2)
            results.close()  # what the exception raised inside the wait does
            workers = descendants(multiprocessing.forkserver._forkserver._forkserver_pid)
            for pid in workers:
                os.kill(pid, signal.SIGKILL)
            end = time.monotonic() + TIMEOUT
            while time.monotonic() < end and any(alive(pid) for pid in workers):
                time.sleep(0.01)
            time.sleep(0.2)  # the manager thread sees its workers gone
            raise KeyboardInterrupt
        for thread in set(threading.enumerate()) - before:
            thread.join(10)
        assert len(workers) == 2
        assert [e.exc_type for e in errors] == []

    @pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
    def test_workers_die_with_parent(self, box, big, sig, short_tmp):
        from tests.helpers import write_test_exr

        rng = np.random.default_rng(5)
        maps = []
        for i in range(400):  # ~12 s of fitting on 2 cores: the signal lands mid-run
            write_test_exr(box / f"m{i}.exr", 0.5 + rng.random((32, 64, 3)))
            maps.append(box / f"m{i}.exr")
        # --samples 64: the first case builds its plan in 0.1 CPU s, not 2 (the plan cache is
        # shared by both cases); the fork server's socket folder goes in short_tmp (kill -9
        # leaves it: an empty folder)
        env = dict(os.environ, NUMBA_NUM_THREADS="1", SHBAKE_CACHE_DIR=str(big / "cache"),
                   TMPDIR=short_tmp)  # fmt: skip
        p = subprocess.Popen(
            [sys.executable, "-m", "shbake_cli.main", "probe-fit", *map(str, maps), "--out-dir",
             str(box / "out"), "--jobs", "2", "--samples", "64", "-q"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        )  # fmt: skip
        try:
            deadline = time.monotonic() + TIMEOUT
            workers = set()
            while time.monotonic() < deadline and p.poll() is None:
                # the fork server and the workers forked from it (shbake.batch.workers)
                workers = {c for c in descendants(p.pid) if "forkserver" in cmdline(c)}
                if len(workers) >= 3 and any((box / "out").glob("*.h5")):
                    break  # the workers are fitting: they wrote a first probe
                time.sleep(0.05)
            assert len(workers) >= 3 and p.poll() is None, p.communicate()[1][-2000:]
            children = descendants(p.pid)
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
            assert os.listdir(short_tmp) == []
        left = [str(f) for f in box.rglob("*") if ".shbake-" in f.name]
        assert not left, left
        assert not (box / "out").exists() or all(f.suffix == ".h5" for f in (box / "out").iterdir())
