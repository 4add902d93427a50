"""``shbake probe-eval`` end to end on a small map: every comparison counted, the report
written, the probes' bytes reported; the SHRM column with its shortfall, ranges and bad ``--eps``.
"""

import json

import pytest

from shbake.batch.probe_eval import shrm_cube_bytes
from tests.helpers import write_test_exr


class TestProbeEvalCli:
    def test_report_and_json(self, probe_maps, tmp_path, run_cli):
        """probe-eval on a small map: every comparison counted over 2 × 6 × 4 cases, the
        Markdown report written, the four probes' bytes reported (the SHRM column:
        tests/batch/test_probe_eval.py)."""
        code, out, err = run_cli("probe-eval", probe_maps[0], "--size", "8", "--samples", "64",
                                 "-o", tmp_path / "eval.md", "--json", "--no-shrm")  # fmt: skip
        assert code == 0, err
        summary = json.loads(out)
        assert all(n == 48 for _, n in summary["totals"].values())
        assert summary["bytes"]["shexp_v2"] == 1056 and summary["bytes"]["shexp_paper"] == 396
        assert "shexp_v2 vs splitsum_plain" in (tmp_path / "eval.md").read_text()


class TestCli:
    @pytest.mark.slow
    def test_shrm_column_with_shortfall_reported(self, tmp_path, run_cli):
        """One low roughness (r 0.3, α 0.09: outside SH-exp's fitted range, so no fit), tiny
        sphere and faces: the SHRM and both split-sums are evaluated in all 8 cases, SH-exp
        has no column, the SHRM's shortfall at ε = 0.01 is printed, the JSON carries its
        orders and bytes (≈ 30 s idle: the split-sum prefilter and ρ̂ to the caps)."""
        from tests.helpers import smooth_map

        src = write_test_exr(tmp_path / "m.exr", smooth_map(32))
        code, out, err = run_cli("probe-eval", src, "--size", "8", "--samples", "64",
                                 "--roughness", "0.3", "--face-size", "8", "--json",
                                 "-o", tmp_path / "r.md")  # fmt: skip
        assert code == 0, err
        summary = json.loads(out)
        assert summary["alphas"] == [0.09]
        assert set(summary["totals"]) == {"shrm vs splitsum_plain", "shrm vs splitsum_filtered"}
        assert summary["totals"]["shrm vs splitsum_plain"][1] == 8
        (row,) = summary["shrm"]["orders"]
        assert not row["E1"]["reached"] and (row["E1"]["F"], row["E1"]["P"]) == (64, 16)
        assert "shbake: warning: SHRM at α 0.09" in err and "not reachable" in err
        nbytes = sum(shrm_cube_bytes(8, row[t]["P"]) for t in ("E0", "E1"))
        assert summary["bytes"]["shrm"] == nbytes and "shexp_v2" not in summary["bytes"]
        text = (tmp_path / "r.md").read_text()
        assert "GGX SHRM" in text and "SH-exp" not in text and "no (capped)" in text

    def test_roughness_out_of_range_is_a_usage_error(self, tmp_path, run_cli):
        code, _, err = run_cli("probe-eval", tmp_path / "m.exr", "--roughness", "0.05")
        assert code == 2 and "--roughness" in err

    def test_bad_eps_one_line(self, tmp_path, run_cli):
        from tests.helpers import smooth_map

        src = write_test_exr(tmp_path / "m.exr", smooth_map(16))
        code, _, err = run_cli("probe-eval", src, "--eps", "0", "-o", tmp_path / "r.md")
        assert code == 2 and "eps" in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "r.md").exists()
