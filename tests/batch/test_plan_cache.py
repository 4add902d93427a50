"""The plan cache (:mod:`shbake.batch.plan_cache`): a cached fit plan and DFG table equal the
fresh ones, unreadable entries are rebuilt, ``SHBAKE_CACHE_DIR=off`` writes nothing.
"""

import numpy as np

from shbake.bakers.dfg import dfg_table
from shbake.bakers.shexp import FitPlan
from tests.probe_cases import SMALL


class TestPlanCache:
    def test_cached_plan_is_the_fresh_plan(self, monkeypatch, tmp_path):
        from shbake.batch.plan_cache import cached_fit_plan

        monkeypatch.setenv("SHBAKE_CACHE_DIR", str(tmp_path))
        fresh = FitPlan(SMALL, (32, 64)).targets
        first = cached_fit_plan(SMALL, (32, 64)).targets  # builds and stores
        (entry,) = tmp_path.glob("plan-*.npz")
        second = cached_fit_plan(SMALL, (32, 64)).targets  # loads
        for q in (first, second):
            assert q.shape == fresh.shape and q.levels == fresh.levels
            for name in ("offsets", "index", "weight", "views", "normals", "alphas"):
                np.testing.assert_array_equal(getattr(q, name), getattr(fresh, name))
        entry.write_bytes(b"not a plan")  # unreadable entries are rebuilt and replaced
        third = cached_fit_plan(SMALL, (32, 64)).targets
        np.testing.assert_array_equal(third.weight, fresh.weight)
        assert entry.stat().st_size > 100

    def test_cached_dfg_table_is_the_fresh_table(self, monkeypatch, tmp_path):
        from shbake.batch.plan_cache import cached_dfg_table

        monkeypatch.setenv("SHBAKE_CACHE_DIR", str(tmp_path))
        first = cached_dfg_table()
        (entry,) = tmp_path.glob("dfg-*.npy")
        np.testing.assert_array_equal(cached_dfg_table(), first)  # loaded
        np.testing.assert_array_equal(first, dfg_table())

    def test_off_writes_nothing(self, monkeypatch, tmp_path):
        from shbake.batch.plan_cache import cache_dir, cached_fit_plan

        monkeypatch.setenv("SHBAKE_CACHE_DIR", "off")
        assert cache_dir() is None
        cached_fit_plan(SMALL, (32, 64))
        assert not list(tmp_path.iterdir())
