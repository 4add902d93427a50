"""Every ``shbake`` example of README.md runs as written, on the sample maps.

The examples run in order (later ones read what earlier ones wrote) in a
scratch folder holding ``sky.exr`` (a copy of a sample map), ``probes.txt``,
``scene.toml`` (tests/scenes/readme.toml) and a link to ``data_samples/``; the
one Dask example gets a local cluster's address in place of ``tcp://host:8786``.
"""

import os
import re
import shlex
import shutil
from pathlib import Path

import pytest
from shbake_cli.main import main

from tests.helpers import ROOT

README = ROOT / "README.md"
PLACEHOLDER_SCHEDULER = "tcp://host:8786"


def readme_commands() -> list[str]:
    """The ``shbake …`` lines of the README's ``sh`` blocks, continuation lines joined."""
    blocks = re.findall(r"```sh\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)
    commands = []
    for block in blocks:
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #", 1)[0].strip()
            if line.startswith("shbake "):
                commands.append(line)
    return commands


COMMANDS = readme_commands()


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("readme")
    os.symlink(ROOT / "data_samples", folder / "data_samples")
    shutil.copy(ROOT / "data_samples" / "forest.exr", folder / "sky.exr")
    shutil.copy(ROOT / "tests" / "scenes" / "readme.toml", folder / "scene.toml")
    (folder / "probes.txt").write_text(
        "# MAP [OUTPUT]\ndata_samples/city.exr\ndata_samples/night.exr night-probe.h5\n"
    )
    return folder


@pytest.fixture(scope="module")
def scheduler():
    if not any(PLACEHOLDER_SCHEDULER in c for c in COMMANDS):
        yield None
        return
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster:  # fmt: skip
        yield cluster.scheduler_address


def test_readme_has_examples():
    assert len(COMMANDS) >= 8, COMMANDS


@pytest.mark.heavy
def test_examples_run_in_order(workdir, scheduler, monkeypatch, capfd):
    """One test, so that xdist keeps the examples in order on one worker."""
    monkeypatch.chdir(workdir)
    for command in COMMANDS:
        run = command.replace(PLACEHOLDER_SCHEDULER, scheduler) if scheduler else command
        argv = []
        for a in shlex.split(run)[1:]:  # the shell's glob
            hits = sorted(Path(".").glob(a)) if any(ch in a for ch in "*?[") else []
            argv += [str(h) for h in hits] or [a]
        code = main(argv)
        err = capfd.readouterr().err
        assert code == 0, f"{command}\n{err}"
        assert "Traceback" not in err, f"{command}\n{err}"


@pytest.mark.skipif(shutil.which("make") is None, reason="GNU make not installed")
def test_demo_venv_holds_no_test_extras():
    """Issue 32: ``make demo`` installs the runtime packages only; ``make test`` adds the
    test extras. Read from ``make -n -B`` (prints every recipe line, runs none)."""
    import subprocess

    def dry(goal: str) -> str:
        return subprocess.run(["make", "-n", "-B", goal], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout  # fmt: skip

    demo = dry("demo")
    assert "pip install -q -c requirements.lock -e .\n" in demo and "[test]" not in demo
    assert "-e '.[test]'" in dry("test")
