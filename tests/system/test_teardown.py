"""Issue 27, item 8: no third-party text after shbake's own last line, ever.

One command per family runs under a pseudo-terminal (progress bars draw) and through
pipes. Whatever it prints must be shbake's own: ``shbake: …`` lines, progress bars, and
the command's documented output (a pattern per command), ending with its last line and a
newline. Before, a bar's tqdm monitor thread (or Dask's client threads) kept the
console script from ending with ``os._exit``, and the interpreter's teardown printed
~43 lines of ``nanobind: leaked 232 instances!`` (OpenImageIO), the last without a
newline; ``bake --scheduler`` printed ``Task exception was never retrieved``.
"""

import fcntl
import os
import re
import select
import shutil
import signal
import struct
import subprocess
import sys
import termios
import time

import numpy as np
import pytest

from tests.faults import computing
from tests.helpers import local_cluster, write_test_exr

TIMEOUT = 240
"""Seconds a command may take (a hang fails the test instead of the suite)."""
ENV = dict(os.environ, NUMBA_NUM_THREADS="1")
SCENE = '[scene]\nname = "t"\n[[environments]]\nmap = "m0.exr"\n[[materials]]\nname = "p"\n' \
    'kind = "diffuse"\n'  # fmt: skip
SHBAKE_LINE = r"shbake: (warning|error): .*"
"""What any command may print besides its own output."""

FAMILIES = {  # arguments, exit status, its own lines, its last line
    "project-env": (["project-env", "{m0}", "-o", "{tmp}/e.h5", "--report"], 0,
                    r"error .* vs brute force\) of .*|cost: baked in .*|band .*|\s+\d+\s.*"
                    r"|fraction of .*"
                    r"|\S+ vs brute force, relative: .*|wrote .*",
                    r"wrote \S+/e\.h5 \(lmax \d+, latlong\)"),
    "brdf-table": (["brdf-table", "phong", "-o", "{tmp}/t.h5", "--size", "8", "--lmax", "2",
                    "--samples", "64"], 0, r"wrote .*|  error: .*", r"  error: f\* rebuilt .*"),
    "probe-fit --jobs 2": (["probe-fit", "{m0}", "{m1}", "--out-dir", "{tmp}/pf", "--jobs", "2",
                            "--normals", "16", "--views", "8"], 0,
                           r"\S+\.exr: error .* vs brute force\) of .*|probe-fit: .*",
                           r"probe-fit: 2 probes in .*"),
    "bake --jobs 2": (["bake", "{tmp}/scene.toml", "--jobs", "2"], 0,
                      r"baked env_sh/m0: .*|bake: .*", r"bake: 1 baked, 0 up to date"),
    "bake --scheduler": (["bake", "{tmp}/scene.toml", "--scheduler", "{cluster}"], 0,
                         r"baked env_sh/m0: .*|bake: .*", r"bake: 1 baked, 0 up to date"),
    "preview --diff": (["preview", "{env}", "--diff", "-o", "{tmp}/p.exr", "--size", "32"], 0,
                       r"irradiance vs brute force: .*|wrote .*", r"wrote \S+/p\.exr .*"),
    "probe-eval": (["probe-eval", "{m0}", "--size", "8", "--samples", "16", "--roughness", "0.5",
                    "--no-shrm"], 0, r"probe-eval: .*", r"probe-eval: .*"),
    "failing run": (["project-env", "{tmp}/missing.exr", "-o", "{tmp}/x.h5"], 1, r"(?!)",
                    r"shbake: error: \S+/missing\.exr: no such file .*"),
    "SIGINT": (["preview", "{big}", "--pass", "reference", "--size", "1024", "-o", "{tmp}/r.exr"],
               130, r"(?!)", r"shbake: error: interrupted"),
}  # fmt: skip


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Two 32x64 maps, an env_sh asset of the first, and one of a 256x512 map."""
    from shbake_cli.main import main

    root = tmp_path_factory.mktemp("teardown")
    rng = np.random.default_rng(11)
    for i in range(2):
        write_test_exr(root / f"m{i}.exr", 0.2 + rng.random((32, 64, 3)))
    write_test_exr(root / "big.exr", 0.2 + rng.random((256, 512, 3)))
    for name, asset in (("m0", "env"), ("big", "big")):
        assert main(["project-env", str(root / f"{name}.exr"), "-o", str(root / f"{asset}.h5"),
                     "-q"]) == 0  # fmt: skip
    return root


@pytest.fixture(scope="module")
def cluster():
    with local_cluster() as address:
        yield address


def command(name: str, inputs, tmp_path, cluster) -> list[str]:
    """The family's command line, with its scene (if any) in ``tmp_path``."""
    shutil.copy(inputs / "m0.exr", tmp_path / "m0.exr")
    (tmp_path / "scene.toml").write_text(SCENE)
    fields = {"m0": inputs / "m0.exr", "m1": inputs / "m1.exr", "env": inputs / "env.h5",
              "big": inputs / "big.h5", "tmp": tmp_path, "cluster": cluster}  # fmt: skip
    return [sys.executable, "-m", "shbake_cli.main",
            *(a.format(**fields) for a in FAMILIES[name][0])]  # fmt: skip


def run_in_terminal(args: list[str], interrupt: bool) -> tuple[int, str]:
    """Run ``args`` with stdin, stdout and stderr on a new pseudo-terminal (120 columns);
    ``(status, what the terminal received)``, read until every writer has closed it
    (pool workers included). ``interrupt``: SIGINT as soon as a progress bar draws."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    p = subprocess.Popen(args, stdin=slave, stdout=slave, stderr=slave, env=ENV,
                         start_new_session=True)  # fmt: skip
    os.close(slave)
    received = b""
    deadline = time.monotonic() + TIMEOUT
    try:
        while time.monotonic() < deadline:
            if not select.select([master], [], [], 0.1)[0]:
                continue
            try:
                data = os.read(master, 1 << 16)
            except OSError:  # EIO: the last writer has closed the terminal
                break
            if not data:
                break
            received += data
            if interrupt and b"\r" in received and p.poll() is None:
                p.send_signal(signal.SIGINT)
                interrupt = False
        return p.wait(timeout=60), received.decode("utf-8", "replace")
    finally:
        os.close(master)
        if p.poll() is None:
            p.kill()
            p.wait()


def run_through_pipes(args: list[str], interrupt: bool) -> tuple[int, str, str]:
    """Run ``args`` with stdout and stderr on pipes; ``(status, stdout, stderr)``.
    ``interrupt``: SIGINT once it computes in its kernel (the ``SIGINT`` family: minutes of
    brute-force reference; through pipes no bar draws to wait for, as under a terminal)."""
    p = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, env=ENV)  # fmt: skip
    try:
        if interrupt:
            assert computing(p), p.communicate()[1][-2000:]
            p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=TIMEOUT)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    return p.returncode, out.decode("utf-8", "replace"), err.decode("utf-8", "replace")


CSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def shown_lines(text: str) -> list[str]:
    """The non-blank lines a terminal shows: what follows the last carriage return of each
    line (a progress bar is redrawn after ``\\r`` and cleared before the next line)."""
    lines = []
    for line in CSI.sub("", text).replace("\r\n", "\n").split("\n"):
        shown = line.split("\r")[-1]
        if shown.strip():
            lines.append(shown)
    return lines


def check_own_lines(text: str, own: str, last: str) -> None:
    """Every shown line is shbake's (``own`` or ``shbake: …``); the last matches ``last``
    and ends with a newline: nothing follows it."""
    lines = shown_lines(text)
    foreign = [x for x in lines if not re.fullmatch(f"{own}|{SHBAKE_LINE}", x)]
    assert not foreign, "\n".join(foreign[:10]) + f"\n… {len(foreign)} foreign lines"
    assert lines and re.fullmatch(last, lines[-1]), lines[-3:]
    assert text.rstrip("\r ").endswith("\n"), repr(text[-200:])


@pytest.mark.parametrize("name", list(FAMILIES))
def test_terminal(inputs, cluster, tmp_path, name):
    args, code, own, last = FAMILIES[name]
    status, text = run_in_terminal(command(name, inputs, tmp_path, cluster), name == "SIGINT")
    assert status == code, text[-3000:]
    check_own_lines(text, own, last)


@pytest.mark.parametrize("name", list(FAMILIES))
def test_pipes(inputs, cluster, tmp_path, name):
    args, code, own, last = FAMILIES[name]
    status, out, err = run_through_pipes(command(name, inputs, tmp_path, cluster),
                                         name == "SIGINT")  # fmt: skip
    assert status == code, err[-3000:]
    assert out == ""
    check_own_lines(err, own, last)
