"""The GGX SHRM figures docs/BENCHMARKS.md reports from ``bench/probe_eval.py --roughness 0.25
0.4 0.5`` (``bench/results/probe_eval_shrm.json``): the cases, the SHRM's wins over the
split-sums, its orders and bytes, and (slow) one map's column recomputed from scratch.
"""

import json
from pathlib import Path

import pytest

from shbake.batch.probe_eval import evaluate_maps, shrm_cube_bytes, win_table
from tests.helpers import map_path

RESULTS = Path(__file__).resolve().parents[2] / "bench" / "results" / "probe_eval_shrm.json"


@pytest.fixture(scope="module")
def three_way():
    return json.loads(RESULTS.read_text())


class TestReportedThreeWay:
    """The figures docs/BENCHMARKS.md reports from ``bench/probe_eval.py --roughness 0.25 0.4
    0.5`` (``bench/results/probe_eval_shrm.json``)."""

    def test_cases(self, three_way):
        assert sorted(three_way["maps"]) == ["city", "esplanade", "forest", "night", "studio",
                                             "sunset"]  # fmt: skip
        assert three_way["alphas"] == [0.0625, 0.16, 0.25]
        assert three_way["size"] == 32 and three_way["truth_samples"] == 4096
        for rows in three_way["maps"].values():
            assert len(rows) == 3 * 2 * 4
            for r in rows:
                assert (r["mse"]["shexp_v2"] is None) == (r["alpha"] < 0.2)
                assert r["mse"]["shrm"] is not None and r["mse"]["splitsum_plain"] is not None

    def test_shrm_beats_split_sum_in_90_percent_at_r_025_and_04(self, three_way):
        low = {"maps": {k: [r for r in rows if r["alpha"] in (0.0625, 0.16)]
                        for k, rows in three_way["maps"].items()}}  # fmt: skip
        for baseline in ("splitsum_plain", "splitsum_filtered"):
            wins, cases = win_table(low, "shrm", baseline)["total"]
            assert cases == 96 and wins == 95 and wins / cases >= 0.90
        assert win_table(three_way, "shrm", "shexp_v2")["total"] == (48, 48)

    def test_orders_and_bytes(self, three_way):
        s = three_way["shrm"]
        assert s["eps"] == 0.01 and s["face_size"] == 64
        got = {row["alpha"]: (row["E0"]["F"], row["E0"]["P"], row["E0"]["reached"],
                              row["E1"]["F"], row["E1"]["P"], row["E1"]["reached"])
               for row in s["orders"]}  # fmt: skip
        assert got == {0.0625: (64, 16, False, 64, 16, False), 0.16: (64, 16, False, 64, 16, False),
                       0.25: (32, 12, True, 64, 16, False)}  # fmt: skip
        nbytes = sum(shrm_cube_bytes(64, row[t]["P"]) for row in s["orders"] for t in ("E0", "E1"))
        assert three_way["bytes"]["shrm"] == nbytes == 475_987_968
        assert three_way["bytes"]["splitsum_plain"] == 4 * 3 * (128**2 + 64**2 + 32**2)


@pytest.mark.slow
def test_recomputed_shrm_column_is_the_reported_one(three_way):
    """city at r 0.4 from scratch (about 3 minutes on one core): the SHRM's MSE in every
    case is the committed one (it depends on the map, α and the orders only)."""
    fresh = evaluate_maps([str(map_path("city"))], three_way["size"], three_way["truth_samples"],
                          roughness=[0.4])  # fmt: skip
    old = [r for r in three_way["maps"]["city"] if r["alpha"] == 0.16]
    for o, n in zip(old, fresh["maps"]["city"], strict=True):
        assert (o["material"], o["yaw"]) == (n["material"], n["yaw"])
        assert n["mse"]["shrm"] == pytest.approx(o["mse"]["shrm"], rel=1e-5)
