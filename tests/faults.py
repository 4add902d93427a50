"""What every failure case checks, shared by the fault tests (test_faults, test_full_disk,
test_hostile_assets, test_scene_safety, test_scheduler, test_teardown): a run in a
subprocess, a run busy in its kernel, a snapshot of folders, "failed with one line" and
"left everything as it was", and full disks."""

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

TIMEOUT = 120
"""Seconds any subprocess case may take (a hang fails the test instead of the suite)."""


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


def shbake(*args, timeout=TIMEOUT, stdout=subprocess.PIPE, env=None, preexec=None):
    """Run ``shbake ARGS`` in a subprocess; ``(status, stdout, stderr)``."""
    full_env = dict(os.environ, NUMBA_NUM_THREADS="1", **(env or {}))
    p = subprocess.run(
        [sys.executable, "-m", "shbake_cli.main", *map(str, args)],
        stdout=stdout, stderr=subprocess.PIPE, text=True, timeout=timeout, env=full_env,
        preexec_fn=preexec,
    )  # fmt: skip
    return p.returncode, p.stdout or "", p.stderr


def computing(p: subprocess.Popen, cpu_seconds: float = 1.0) -> bool:
    """Wait until the main thread of ``p`` has run ``cpu_seconds`` of CPU time without a read
    system call (Linux ``/proc``, the thread's ``stat`` and ``io``): its imports, numba's
    cached kernels and its inputs are loaded (all read files) and it computes, inside a long
    kernel. Unlike a fixed sleep this holds on a loaded machine. ``False`` if ``p`` ended
    first, or (killed) after :data:`TIMEOUT` seconds."""
    task = f"/proc/{p.pid}/task/{p.pid}"
    tick = os.sysconf("SC_CLK_TCK")
    reads = since = None
    deadline = time.monotonic() + TIMEOUT
    while p.poll() is None:  # a zombie's files stay readable until this poll reaps it
        stat = Path(f"{task}/stat").read_text().rsplit(")", 1)[1].split()
        cpu = (int(stat[11]) + int(stat[12])) / tick  # utime + stime
        syscr = int(Path(f"{task}/io").read_text().split("syscr:")[1].split()[0])
        if syscr != reads:
            reads, since = syscr, cpu
        elif cpu - since >= cpu_seconds:
            return True
        if time.monotonic() > deadline:
            p.kill()
            p.wait()
            return False
        time.sleep(0.05)
    return False


def snapshot(*folders) -> dict:
    """``path → bytes`` (or ``"dir"``) of everything under ``folders``, hidden files too."""
    out = {}
    for folder in folders:
        for root, dirs, files in os.walk(folder):
            for d in dirs:
                out[os.path.join(root, d)] = "dir"
            for f in files:
                p = os.path.join(root, f)
                if os.path.isfile(p) and not os.path.islink(p):
                    out[p] = Path(p).read_bytes()
                else:
                    out[p] = "special"
    return out


def assert_failed(result, code=1, fragment=None):
    """Exit ``code``, one ``shbake: error:`` line, no traceback; return the message."""
    status, _, err = result
    lines = [x for x in err.splitlines() if x.startswith("shbake: error:")]
    assert status == code, f"exit {status}, stderr: {err[-2000:]}"
    assert len(lines) == 1, err[-2000:]
    assert "Traceback" not in err and "Exception ignored" not in err, err[-2000:]
    if fragment is not None:
        assert fragment in lines[0], lines[0]
    return lines[0]


@contextlib.contextmanager
def unchanged(*folders):
    """Assert that the block leaves ``folders`` exactly as they were (no new file)."""
    before = snapshot(*folders)
    yield
    after = snapshot(*folders)
    new = sorted(set(after) - set(before))
    gone = sorted(set(before) - set(after))
    changed = sorted(p for p in before if p in after and before[p] != after[p])
    assert not (new or gone or changed), f"new {new}, gone {gone}, changed {changed}"


TMPFS_SIZE = "2m"


def can_mount() -> bool:
    """Root on Linux (``SHBAKE_TEST_NO_MOUNT=1`` tries the injected faults instead)."""
    if os.environ.get("SHBAKE_TEST_NO_MOUNT"):
        return False
    return hasattr(os, "geteuid") and os.geteuid() == 0 and sys.platform.startswith("linux")


def file_size_limit():
    """``preexec_fn``: writing past a file's current end fails (``EFBIG``, ``SIGXFSZ``
    ignored) — a full disk for a user who cannot mount one."""
    import resource

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))


def fill(folder: Path) -> None:
    """Fill the file system of ``folder`` to the last byte."""
    fd = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT, 0o644)
    try:
        for size in (65536, 4096, 1):
            with contextlib.suppress(OSError):
                while os.write(fd, b"\0" * size) == size:
                    pass
    finally:
        os.close(fd)


PREVIEW_OF_KIND = {
    "env_sh": lambda a, out: ["preview", a, "-o", out, "--size", 8],
    "shexp_probe": lambda a, out: ["preview", a, "-o", out, "--size", 8],
    "shexp_probe_set": lambda a, out: ["preview", a, "-o", out, "--size", 8],
    "splitsum_probe": lambda a, out: ["preview", a, "-o", out, "--size", 8],
}
