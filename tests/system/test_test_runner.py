"""How ``make test`` runs the suite: ``pytest -n 2 --dist loadgroup``.

Tests that share an expensive fixture carry one ``xdist_group`` mark so that a single worker
builds it (the two-map scene bake, the export bakes, the golden commands, the browser of the
engine and WebGL pages). pytest-xdist 3.8.0 with pytest 9.2.0 dropped the marks silently (the
group rides on the node id, which pytest 9.2 no longer lets a plugin change:
pytest-dev/pytest-xdist#1386), so every such fixture was built on both workers; the pins in
setup.cfg keep a pair that honours them, and this test fails on a pair that does not.
"""

import os
import subprocess
import sys

from tests.helpers import ROOT

GROUPED = """
import os

import pytest

pytestmark = pytest.mark.xdist_group("one")


@pytest.mark.parametrize("i", range(8))
def test_worker(i):
    with open(os.environ["WORKERS_LOG"], "a") as log:
        log.write(os.environ["PYTEST_XDIST_WORKER"] + "\\n")
"""


def test_an_xdist_group_runs_on_one_worker(tmp_path):
    (tmp_path / "test_grouped.py").write_text(GROUPED)
    (tmp_path / "pytest.ini").write_text("[pytest]\n")  # not the project's options
    log = tmp_path / "workers.log"
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadgroup",
         "-p", "no:cacheprovider", str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, env=env | {"WORKERS_LOG": str(log)},
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    workers = log.read_text().split()
    assert len(workers) == 8 and len(set(workers)) == 1, workers


def test_heavy_tests_are_collected_first():
    """A ``heavy`` test leads the collection (tests/conftest.py), so that ``--dist loadgroup``
    hands it out right after the groups (the README examples, first in no file order)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "tests/system/test_readme.py"],
        cwd=ROOT, capture_output=True, text=True, env=env,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    ids = [line for line in run.stdout.splitlines() if "::" in line]
    assert len(ids) == 3 and ids[0].endswith("::test_examples_run_in_order"), ids
