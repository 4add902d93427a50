"""``shbake probe-eval`` end to end on a small map: every comparison counted, the report
written, the probes' bytes reported (the SHRM column: ``tests/batch/test_probe_eval.py``).
"""

import json


class TestProbeEvalCli:
    def test_report_and_json(self, probe_maps, tmp_path, run_cli):
        """probe-eval on a small map: every comparison counted over 2 × 6 × 4 cases, the
        Markdown report written, the four probes' bytes reported (the SHRM column:
        tests/test_probe_eval_shrm.py)."""
        code, out, err = run_cli("probe-eval", probe_maps[0], "--size", "8", "--samples", "64",
                                 "-o", tmp_path / "eval.md", "--json", "--no-shrm")  # fmt: skip
        assert code == 0, err
        summary = json.loads(out)
        assert all(n == 48 for _, n in summary["totals"].values())
        assert summary["bytes"]["shexp_v2"] == 1056 and summary["bytes"]["shexp_paper"] == 396
        assert "shexp_v2 vs splitsum_plain" in (tmp_path / "eval.md").read_text()
