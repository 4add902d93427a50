"""``shbake probe-fit`` (and ``split-sum``) end to end: probe sets equal the single probes,
``--report``/``--tol``, sizes in bytes, bad options and maps refused in one line.
"""

import filecmp
import json

import numpy as np
import pytest
from shbake_cli.main import main

from shbake.format.asset import read_asset
from tests.helpers import smooth_map, write_test_exr


class TestProbeSet:
    def test_set_holds_the_single_probes(self, probe_maps, tmp_path, run_cli):
        """A set's probe i is bit for bit the probe of the single-file run; the set file
        is byte-identical between --jobs 1 and 2 (and the deprecated --set); preview reads a
        probe by --index."""
        opts = ["--normals", "16", "--views", "16", "--samples", "256", "-q"]
        assert run_cli("probe-fit", *probe_maps, "--out-dir", tmp_path, *opts)[0] == 0
        for jobs in ("1", "2"):
            out = tmp_path / f"set{jobs}.h5"
            assert run_cli("probe-fit", *probe_maps, "-o", out, "--jobs", jobs, *opts)[0] == 0
        assert filecmp.cmp(tmp_path / "set1.h5", tmp_path / "set2.h5", shallow=False)
        code, _, err = run_cli("probe-fit", *probe_maps, "--set", tmp_path / "old.h5", *opts)
        assert code == 0 and "--set is deprecated" in err
        assert filecmp.cmp(tmp_path / "set1.h5", tmp_path / "old.h5", shallow=False)
        probe_set = read_asset(str(tmp_path / "set1.h5"), ("shexp_probe_set",))
        assert probe_set["/p"].shape == (4, 2, 36, 3) and probe_set["/q"].shape == (4, 2, 8, 3)
        for i in range(4):
            single = read_asset(str(tmp_path / f"m{i}.h5"), ("shexp_probe",))
            np.testing.assert_array_equal(probe_set["/p"][i], single["/p"])
            np.testing.assert_array_equal(probe_set["/q"][i], single["/q"])
        code, _, err = run_cli("preview", tmp_path / "set1.h5", "--index", "3", "-o",
                               tmp_path / "p3.exr", "--size", "16", "-q")  # fmt: skip
        assert code == 0 and (tmp_path / "p3-sheet.png").exists()
        code, _, err = run_cli("preview", tmp_path / "set1.h5", "--index", "4", "-o",
                               tmp_path / "p4.exr")  # fmt: skip
        assert code == 1 and "outside this set of 4 probes" in err


class TestFitReport:
    def test_report_and_tol(self, probe_maps, tmp_path, run_cli):
        """--report measures target error against the 65 536-sample plain estimate
        (falling with samples) and the fit residual by order; --tol picks the fewest
        samples within the tolerance, and an unreachable one is a one-line error."""
        opts = ["--normals", "16", "--views", "16", "--out-dir", tmp_path, "--json"]
        code, out, err = run_cli("probe-fit", probe_maps[0], *opts, "--report", "--tol", "0.01")
        assert code == 0, err
        summary = json.loads(out)
        rows = summary["samples_study"]
        errors = [r["target_log_rms"] for r in rows]
        assert errors[-1] < errors[0] and errors[-1] < 1e-2  # pyramid filtering bias remains
        chosen = summary["chosen_samples"]
        assert summary["config"]["samples"] == chosen
        assert chosen == min(r["samples"] for r in rows if r["target_log_rms"] <= 0.01)
        orders = {(r["lmax_p"], r["lmax_q"]): r for r in summary["orders_study"]}
        assert orders[(4, 2)]["bytes"] == 792  # two sets
        assert orders[(8, 4)]["fit_log_rms"] <= orders[(2, 1)]["fit_log_rms"]
        by_alpha = summary["alpha_study"]
        assert [r["alpha"] for r in by_alpha] == pytest.approx(np.linspace(0.2, 1, 8))
        assert all(0 < r["shaded_relative_rms"] < 0.5 for r in by_alpha)
        assert "target error (log RMS)" in err and "fit shaded error" in err
        code, _, err = run_cli("probe-fit", probe_maps[0], *opts, "--tol", "1e-9")
        assert code == 1 and "meets --tol" in err and len(err.strip().splitlines()) == 1


class TestCli:
    def test_probe_fit_and_split_sum(self, probe_maps, tmp_path, capsys):
        rc = main(["probe-fit", probe_maps[0], "--out-dir", str(tmp_path), "--normals", "16",
                   "--views", "16", "--samples", "256", "--json", "-q"])  # fmt: skip
        assert rc == 0 and '"bytes": 1056' in capsys.readouterr().out
        rc = main(["probe-fit", probe_maps[0], "-o", str(tmp_path / "paper.h5"), "--sets", "1",
                   "--weights", "log", "--alpha-count", "4", "--polish", "0", "--normals", "16",
                   "--views", "16", "--samples", "256", "--lmax-p", "4", "--json",
                   "-q"])  # fmt: skip
        assert rc == 0 and '"bytes": 396' in capsys.readouterr().out
        rc = main(["split-sum", probe_maps[0], "-o", str(tmp_path / "s.h5"), "--size", "32",
                   "--samples", "256", "--prefilter", "filtered", "--roughness-levels",
                   "0.5,1", "-q"])  # fmt: skip
        asset = read_asset(str(tmp_path / "s.h5"))
        assert rc == 0 and asset.kind == "splitsum_probe" and asset.attrs["prefilter"] == "filtered"
        np.testing.assert_array_equal(asset["/level_alpha"], [0.25, 1.0])

    @pytest.mark.parametrize(
        "args, message",
        [
            (["--alpha-range", "0:2"], "alpha range"),
            (["--alpha-range", "0.2:1", "--roughness-range", "0.5:1"], "not both"),
            (["--weights", "l1"], "is not one of"),
            (["--sets", "4", "--alpha-count", "4"], "alpha_count"),
            (["--jobs", "0"], "--jobs"),
        ],
    )
    def test_bad_options_one_line(self, probe_maps, tmp_path, capsys, args, message):
        rc = main(["probe-fit", probe_maps[0], "--out-dir", str(tmp_path), *args])
        err = capsys.readouterr().err.strip()
        assert rc != 0 and message in err and "\n" not in err
        assert not list(tmp_path.glob("*.h5"))

    def test_nan_map_refused(self, tmp_path, capsys):
        img = smooth_map(32)
        img[3, 4] = np.nan
        write_test_exr(tmp_path / "nan.exr", img)
        rc = main(["probe-fit", str(tmp_path / "nan.exr"), "--out-dir", str(tmp_path)])
        err = capsys.readouterr().err.strip()
        assert rc == 1 and "NaN" in err and "\n" not in err
        assert not (tmp_path / "nan.h5").exists()
