"""``shbake tradeoff``: the numbers behind the plot agree with the planner's error model."""

import csv
import json

import numpy as np
import pytest

from shbake.batch.plan import irradiance_truncation
from shbake.envmap import load_environment
from shbake.envmap.sun import extract_sun
from shbake.sh.kernels import lambert_kernel
from tests.helpers import map_path


class TestTradeoffCommand:
    def test_env_sh(self, tmp_path, run_cli):
        png, csv_path, js = tmp_path / "t.png", tmp_path / "t.csv", tmp_path / "t.json"
        code, _, err = run_cli("tradeoff", "env_sh", "--map", map_path("studio"), "--tol", "0.02",
                               "-o", png, "--csv", csv_path, "--json-file", js)  # fmt: skip
        assert code == 0, err
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        data = json.loads(js.read_text())
        rows = list(csv.DictReader(csv_path.open()))
        assert [int(r["lmax"]) for r in rows] == list(range(17))
        chosen = [r for r in rows if r["chosen"] == "1"]
        assert len(chosen) == 1 and chosen[0]["setting"] == data["chosen"]
        # the chosen lmax is the smallest whose error meets the tolerance
        errs = [float(r["error"]) for r in rows]
        L = int(chosen[0]["lmax"])
        assert errs[L] <= 0.02 and all(e > 0.02 for e in errs[:L])
        # the line names the choice with its error, time and bytes (the CSV's numbers)
        assert (f"chosen lmax {L} (relative RMS irradiance error (Parseval) {errs[L]:.3g}, "
                f"{float(rows[L]['seconds']) * 1e3:.3g} ms, {rows[L]['bytes']} bytes)") in err
        # independent of the command: the Lambert error of the sun-free map at that lmax
        env = load_environment(str(map_path("studio")), quiet=True)
        e = irradiance_truncation(extract_sun(env)[1].project(32), lambert_kernel)
        assert float(rows[L]["irradiance_error"]) == pytest.approx(e[L], rel=1e-9)
        assert np.all(np.diff([int(r["bytes"]) for r in rows]) > 0)

    def test_brdf_table(self, tmp_path, run_cli):
        code, out, err = run_cli("tradeoff", "brdf_table", "--model", "ashikhmin-shirley",
                                 "-p", "nu=4", "-p", "nv=1", "--tol", "0.25",
                                 "-o", tmp_path / "b.png", "--json", "-q")  # fmt: skip
        assert code == 0, err
        data = json.loads(out)
        assert len(data["rows"]) == 12
        chosen = next(r for r in data["rows"] if r["setting"] == data["chosen"])
        assert chosen["error"] <= 0.25
        # truncation does not depend on the size; the look-up error shrinks with it
        for L in (2, 4, 6, 8):
            rows = [r for r in data["rows"] if r["lmax"] == L]
            assert len({round(r["truncation_error"], 12) for r in rows}) == 1
            assert rows[0]["lookup_error"] > rows[-1]["lookup_error"]

    def test_unmet_tolerance_warns(self, tmp_path, run_cli):
        """No setting meets the tolerance: one warning (stderr and ``--json``) naming the least
        error any setting reaches and where, ``chosen`` null; exit 0 (a study, not a bake)."""
        code, out, err = run_cli("tradeoff", "env_sh", "--map", map_path("sunset"), "--tol",
                                 "1e-9", "-o", tmp_path / "t.png", "--json")  # fmt: skip
        assert code == 0, err
        data = json.loads(out)
        best = min(data["rows"], key=lambda r: r["error"])
        assert data["chosen"] is None and all(r["error"] > 1e-9 for r in data["rows"])
        (warning,) = data["warnings"]
        assert warning == (f"no setting meets --tol 1e-09 (relative RMS irradiance error "
                           f"(Parseval)); the least error is {best['error']:.3g}, at "
                           f"{best['setting']}")  # fmt: skip
        assert f"shbake: warning: {warning}" in err

    def test_needs_its_input(self, tmp_path, run_cli):
        code, _, err = run_cli("tradeoff", "env_sh", "-o", tmp_path / "x.png")
        assert code == 1 and "needs --map" in err

    @pytest.mark.parametrize(("where", "fragment"), [("csv over the map", "destroy the input"),
                                                     ("missing folder", "does not exist")])
    def test_outputs_checked_before_the_sweep(self, tmp_path, run_cli, monkeypatch, where,
                                              fragment):  # fmt: skip
        """A ``--csv`` that is the map, or a plot in a missing folder, is one line before any
        candidate is measured (the input is never harmed either way)."""
        import shutil

        from shbake.batch import tradeoff as module
        from tests.faults import assert_failed, unchanged

        monkeypatch.setattr(module, "warm_seconds", lambda *a: pytest.fail("swept first"))
        shutil.copy(map_path("city"), tmp_path / "m.exr")
        out = ["-o", tmp_path / "t.png", "--csv", tmp_path / "m.exr"]
        if where == "missing folder":
            out = ["-o", tmp_path / "no" / "t.png"]
        with unchanged(tmp_path):
            assert_failed(run_cli("tradeoff", "env_sh", "--map", tmp_path / "m.exr", *out),
                          fragment=fragment)  # fmt: skip


class TestBrdfTableTradeoff:
    @staticmethod
    def measured(times):
        """A stand-in for :func:`~shbake.batch.plan_costs.warm_seconds` returning ``times`` in
        turn."""
        left = iter(times)
        return lambda *a, **k: next(left)

    def test_choice_is_the_planners_whatever_the_seconds(self, monkeypatch):
        """The chosen setting is the one ``shbake plan`` picks (its lmax, then the smallest
        size meeting the tolerance), from the errors alone: measured seconds that make the
        last row the fastest, then the first, change nothing (a noisy machine once marked
        different settings on two runs of the same inputs)."""
        from shbake.batch import tradeoff
        from shbake.batch.plan import TABLE_SAMPLES, plan_brdf_table

        params, tol, samples = {"nu": "4", "nv": "1"}, 0.25, TABLE_SAMPLES[0]
        chosen = []
        # 12 rows (lmax × size): the last one fastest, then the first
        for times in (np.arange(12.0, 0, -1), np.arange(1.0, 13)):
            monkeypatch.setattr(tradeoff, "warm_seconds", self.measured(times))
            result = tradeoff.brdf_table_tradeoff("ashikhmin-shirley", params, tol, samples)
            assert [r["seconds"] for r in result["rows"]] == list(times)
            chosen.append(result["chosen"])
        plan = plan_brdf_table("ashikhmin-shirley", params, None, tol)["settings"]
        assert plan["samples"] == samples  # the planner's candidates are the tradeoff's rows
        assert chosen == [f"lmax {plan['lmax']} size {plan['size']}"] * 2
