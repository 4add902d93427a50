"""SH-exp v2 probe-fit throughput on local worker processes, and Dask byte identity.

Usage: ``python bench/probe_throughput.py [--probes 200] [--jobs 2] [--dask 60]``

Probe lists cycle the six shared 512×256 maps (each probe its own output
file) and run through :func:`shbake.batch.probe_jobs.run_local` with
``--jobs`` spawned workers (numba on one thread each; targets of 8 probes
gathered per pass). Two runs, of ``SHORT`` and of ``--probes`` probes, each
in a fresh pool, give the steady rate ``(N − SHORT)/(t_N − t_SHORT)`` and the
fixed per-run cost ``t_SHORT − SHORT/rate`` (pool start, imports, numba
cache loading, each worker's plan load from the on-disk cache). The plan
build itself (first run on a machine) is timed apart, before both. On a
shared machine wall times measure the load more than the code, so the CPU
time one process spends per probe (batches of 8, after a warm-up batch) is
reported too, with the rate two cores would give at that CPU time. ``--dask``
fits the first ``N`` probes on a ``--jobs``-worker Dask LocalCluster and
compares every file byte for byte with the local run's. OpenBLAS runs one thread unless
``OPENBLAS_NUM_THREADS`` says otherwise, as in ``shbake`` itself. Output: Markdown.
"""

import argparse
import filecmp
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the command line runs (cli/__init__.py)

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
SHORT = 16


def map_path(name: str) -> Path:
    shared = ROOT.parent / "shared" / "hdri" / f"{name}.exr"
    return shared if shared.exists() else ROOT / "data_samples" / f"{name}.exr"


def jobs_for(n: int, folder: Path):
    from shbake.bakers.shexp import FitConfig
    from shbake.batch.probe_jobs import ProbeJob

    folder.mkdir(parents=True, exist_ok=True)
    return [ProbeJob(str(map_path(MAPS[i % len(MAPS)])), str(folder / f"p{i:05d}.h5"),
                     FitConfig()) for i in range(n)]  # fmt: skip


def cpu_per_probe(folder: Path, probes: int = 48) -> float:
    """CPU milliseconds per probe of :func:`run_probe_batch` in this process (numba on one
    thread), after one warm-up batch."""
    from shbake.batch.probe_jobs import GATHER_BATCH, run_probe_batch
    from shbake.jit import use_one_thread

    use_one_thread()
    jobs = jobs_for(probes + GATHER_BATCH, folder)
    run_probe_batch(jobs[:GATHER_BATCH])
    t0 = time.process_time()
    for i in range(GATHER_BATCH, len(jobs), GATHER_BATCH):
        run_probe_batch(jobs[i : i + GATHER_BATCH])
    return 1e3 * (time.process_time() - t0) / probes


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--probes", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--dask", type=int, default=0, help="probes to fit on Dask (0: none)")
    args = ap.parse_args()
    from shbake.bakers.shexp import FitConfig
    from shbake.batch.plan_cache import cached_dfg_table, cached_fit_plan
    from shbake.batch.probe_jobs import run_dask, run_local
    from shbake.envmap import load_environment

    t0 = time.perf_counter()
    env = load_environment(str(map_path(MAPS[0])), quiet=True)
    cached_fit_plan(FitConfig(), env.shape)
    cached_dfg_table()
    plan_seconds = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cpu_ms = cpu_per_probe(tmp / "cpu")
        t0 = time.perf_counter()
        run_local(jobs_for(SHORT, tmp / "short"), args.jobs)
        t_short = time.perf_counter() - t0
        local = jobs_for(args.probes, tmp / "local")
        t0 = time.perf_counter()
        run_local(local, args.jobs)
        t_long = time.perf_counter() - t0
        rate = (args.probes - SHORT) / (t_long - t_short)
        fixed = t_short - SHORT / rate
        print(f"| probes | wall s (--jobs {args.jobs}) |\n|---|---|")
        print(f"| {SHORT} | {t_short:.2f} |\n| {args.probes} | {t_long:.2f} |")
        print(f"\nsteady rate: **{rate:.1f} probes/s**; fixed per-run cost {fixed:.2f} s "
              f"(pool, imports, plan load); plan build or cache check before: {plan_seconds:.2f} s")
        print(f"\nCPU time per probe (one process, load, fit, write): {cpu_ms:.1f} ms → "
              f"{2000 / cpu_ms:.1f} probes/s on 2 cores at that CPU time")
        if args.dask:
            from distributed import LocalCluster

            dask_jobs = jobs_for(args.dask, tmp / "dask")
            with LocalCluster(n_workers=args.jobs, threads_per_worker=1, host="127.0.0.1",
                              dashboard_address=None) as cluster:  # fmt: skip
                t0 = time.perf_counter()
                run_dask(dask_jobs, cluster.scheduler_address)
                t_dask = time.perf_counter() - t0
            same = sum(filecmp.cmp(a.output, b.output, shallow=False)
                       for a, b in zip(local, dask_jobs, strict=False))  # fmt: skip
            print(f"\nDask LocalCluster ({args.jobs} workers): {args.dask} probes in "
                  f"{t_dask:.2f} s; {same}/{args.dask} files byte-identical to the local run")


if __name__ == "__main__":
    main()
