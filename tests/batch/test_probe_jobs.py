"""Probe jobs (:mod:`shbake.batch.probe_jobs`): one and two local processes and a 2-worker
Dask cluster write byte-identical probe files.
"""

import filecmp

from shbake.batch.probe_jobs import ProbeJob, run_dask, run_local
from shbake.format.asset import read_asset
from tests.probe_cases import SMALL


class TestBatch:
    def test_jobs_and_dask_write_identical_files(self, probe_maps, tmp_path):
        def jobs(folder):
            (tmp_path / folder).mkdir()
            return [
                ProbeJob(p, str(tmp_path / folder / f"p{i}.h5"), SMALL)
                for i, p in enumerate(probe_maps)
            ]

        run_local(jobs("one"), 1)
        run_local(jobs("two"), 2)
        from distributed import LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1",
                          dashboard_address=":0") as cluster:  # fmt: skip
            run_dask(jobs("dask"), cluster.scheduler_address)
        for i in range(len(probe_maps)):
            a = tmp_path / "one" / f"p{i}.h5"
            assert filecmp.cmp(a, tmp_path / "two" / f"p{i}.h5", shallow=False)
            assert filecmp.cmp(a, tmp_path / "dask" / f"p{i}.h5", shallow=False)
        asset = read_asset(str(tmp_path / "one" / "p0.h5"), ("shexp_probe",))
        assert asset["/p"].shape == (2, 36, 3) and asset["/q"].shape == (2, 8, 3)
