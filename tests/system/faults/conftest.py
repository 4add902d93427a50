"""Fixtures of the fault suites (issue 11): a workspace of a tiny map and one asset of each
kind, a fresh folder per test holding copies, and a small tmpfs where one may be mounted."""

import subprocess

import pytest

from shbake.format.asset import write_asset
from tests.assets_examples import example, write_map
from tests.faults import TMPFS_SIZE, can_mount


@pytest.fixture(scope="session")
def ws(tmp_path_factory):
    """A workspace: a tiny map, an env_sh asset of it, old outputs, a probe and a table (read
    only; built once for the fault files, as when they were one file)."""
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
