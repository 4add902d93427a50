"""Start-up (issue 15): a command imports only what its options use; a script run exits cleanly.

Each case runs in a fresh interpreter (the test session itself has loaded
everything). numba costs ~200 ms to import and scipy.ndimage ~300 ms, so a
small bake must load neither; ``--window dering`` may load scipy.optimize
(not scipy.ndimage, which only ``--fix-nonfinite box3`` uses).
"""

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

from tests.helpers import ROOT, map_path

PROBE = """
import json, sys
from shbake_cli.main import main
try:
    code = main(sys.argv[1:])
except SystemExit as e:
    code = e.code
mods = sorted({m for m in sys.modules if m.split(".")[0] in ("scipy", "numba", "dask", "mitsuba")})
print(json.dumps({"code": code, "modules": mods}))
"""


def loaded(*args) -> set[str]:
    res = subprocess.run(
        [sys.executable, "-c", PROBE, *map(str, args)],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    )
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert out["code"] in (0, None), res.stderr
    return set(out["modules"])


def scipy_subpackages(mods):
    return {
        m.split(".")[1]
        for m in mods
        if m.startswith("scipy.") and not m.split(".")[1].startswith("_")
    }


class TestImportsPerCommand:
    def test_project_env_help(self):
        mods = loaded("project-env", "--help")
        assert not any(m.startswith(("scipy", "numba")) for m in mods), mods

    @pytest.mark.parametrize("lmax", [2, 8])
    def test_small_bake_loads_neither_scipy_nor_numba(self, tmp_path, lmax):
        out = tmp_path / "e.h5"
        mods = loaded("project-env", map_path("esplanade"), "-o", out, "-q", "--lmax", lmax)
        assert not any(m.startswith(("scipy", "numba")) for m in mods), sorted(mods)[:10]
        assert out.exists()

    def test_dering_loads_only_scipy_optimize(self, tmp_path):
        mods = loaded(
            "project-env", map_path("forest"), "-o", tmp_path / "e.h5", "-q", "--window", "dering"
        )
        subs = scipy_subpackages(mods)
        assert "optimize" in subs  # (which itself pulls in linalg, sparse, fft, …)
        assert "ndimage" not in subs, subs


class TestScriptExit:
    def test_console_script_writes_complete_outputs(self, tmp_path):
        # The console script ends with os._exit once outputs are closed: stdout
        # must still be complete and the asset readable.
        out = tmp_path / "e.h5"
        res = subprocess.run(
            [
                str(ROOT / ".venv" / "bin" / "shbake"),
                "project-env",
                map_path("city"),
                "-o",
                out,
                "--json",
                "-q",
                "--lmax",
                "4",
            ],
            capture_output=True,
            text=True,
            check=True,
        )
        summary = json.loads(res.stdout)
        with h5py.File(out, "r") as f:
            L = f["lighting/sh"][()]
        assert L.shape == (25, 3)
        np.testing.assert_allclose(summary["lighting_L00"], L[0])

    def test_collector_paused_for_imports_then_running(self, tmp_path):
        # A script run pauses the cyclic collector while the subcommand's modules load,
        # then freezes what they created and turns it back on for the command itself.
        probe = (
            "import gc, json, os, sys\n"
            "import shbake_cli.main as m\n"
            "real_import = m.importlib.import_module\n"
            "during = []\n"
            "def watched_import(name):\n"
            "    during.append(gc.isenabled())\n"
            "    return real_import(name)\n"
            "m.importlib = type('I', (), {'import_module': staticmethod(watched_import)})\n"
            "def report(code):\n"
            "    print(json.dumps({'code': code, 'during': during, 'enabled': gc.isenabled(),\n"
            "                      'frozen': gc.get_freeze_count()}))\n"
            "    sys.stdout.flush()\n"
            "    os._exit(0)\n"
            "m._fast_exit = report\n"
            "sys.argv = ['shbake', *sys.argv[1:]]\n"
            "m.main()\n"
        )
        out = tmp_path / "e.h5"
        res = subprocess.run(
            [sys.executable, "-c", probe, "project-env", map_path("city"), "-o", out, "-q"],
            capture_output=True,
            text=True,
            check=True,
            cwd=ROOT,
        )
        state = json.loads(res.stdout.strip().splitlines()[-1])
        assert state["code"] == 0, res.stderr
        assert state["during"] == [False]
        assert state["enabled"]
        assert state["frozen"] > 10_000  # numpy, h5py, OpenImageIO and shbake's modules
