"""``shbake probe-eval`` end to end on a small map: every comparison counted, the report
written, the probes' bytes and bake seconds reported; the SHRM column with its shortfall, ranges
and bad ``--eps``.
"""

import collections
import json
import math
import time

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

    def test_bake_seconds_per_map_in_json_and_report(self, probe_maps, tmp_path, run_cli):
        """``--no-shrm`` on two maps: ``seconds`` per map for exactly the four probes baked
        (no ``shrm``), each finite and positive; the report's bytes table gives their mean."""
        code, out, err = run_cli("probe-eval", *probe_maps[:2], "--size", "8", "--samples", "16",
                                 "--roughness", "0.5", "--no-shrm", "--json",
                                 "-o", tmp_path / "eval.md")  # fmt: skip
        assert code == 0, err
        summary = json.loads(out)
        probes = {"shexp_v2", "shexp_paper", "splitsum_plain", "splitsum_filtered"}
        assert list(summary["seconds"]) == ["m0", "m1"] and set(summary["bytes"]) == probes
        for secs in summary["seconds"].values():
            assert set(secs) == probes
            assert all(math.isfinite(v) and v > 0 for v in secs.values()), secs
        text = (tmp_path / "eval.md").read_text()
        assert "| probe | bytes per probe | bake s (mean of 2 maps) |" in text
        line = next(x for x in err.splitlines() if x.startswith("probe-eval: bake s"))
        assert line.startswith("probe-eval: bake s (mean of 2 maps): ")
        for k in probes:
            mean = (summary["seconds"]["m0"][k] + summary["seconds"]["m1"][k]) / 2
            assert f"| {k} | {summary['bytes'][k]} | {mean:.3g} |" in text
            assert f"{k} {mean:.3g}" in line

    def test_maps_of_one_name_refused(self, probe_maps, tmp_path, run_cli):
        """Results are kept per file stem: two maps of one name (in two folders) are refused
        in one line before any work, instead of the second silently replacing the first."""
        (tmp_path / "b").mkdir()
        other = tmp_path / "b" / "m0.exr"
        other.write_bytes(open(probe_maps[0], "rb").read())
        code, out, err = run_cli("probe-eval", probe_maps[0], other, "--size", "8",
                                 "--samples", "16", "--no-shrm")  # fmt: skip
        assert code == 2 and out == "", err
        assert err.strip().splitlines() == [
            "shbake: error: maps named 'm0' are given more than once: results are kept per "
            "file name (without its suffix)"
        ]

    def test_shrm_seconds_count_its_bakes(self, probe_maps, run_cli, monkeypatch):
        """Every ``bake_shrm`` call slowed by 0.2 s (r 0.5: one E0 and one E1 per map, 4² faces,
        ε 0.5): each map's ``shrm`` seconds are at least 0.2 s per call made for it."""
        import shbake.bakers.shrm as shrm_module

        calls, original = [], shrm_module.bake_shrm

        def slow(env, *args, **kwargs):
            calls.append(env)  # held: the maps' ids stay distinct
            time.sleep(0.2)
            return original(env, *args, **kwargs)

        monkeypatch.setattr(shrm_module, "bake_shrm", slow)
        code, out, err = run_cli("probe-eval", *probe_maps[:2], "--size", "8", "--samples", "16",
                                 "--roughness", "0.5", "--eps", "0.5", "--face-size", "4",
                                 "--json")  # fmt: skip
        assert code == 0, err
        seconds = json.loads(out)["seconds"]
        per_map = list(collections.Counter(id(e) for e in calls).values())
        assert per_map == [2, 2]
        for stem, n in zip(("m0", "m1"), per_map, strict=True):
            assert seconds[stem]["shrm"] >= 0.2 * n


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
