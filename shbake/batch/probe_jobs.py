"""Probe fitting as pure units of work: a spec in, one file out.

A :class:`ProbeJob` names its map, its output and its configuration; running
it reads the map, fits the probe and writes the asset atomically. Nothing in
the asset depends on where or when the job ran (no times, no host, no
scheduling options), so running a job twice, locally or on a Dask worker,
gives byte-identical files. The probe-independent state — the
:class:`~shbake.bakers.shexp.FitPlan` (sample directions, their texels and
weights, the design matrix) and the DFG table — is built once per process
and reused by every job that shares its configuration and map shape.
"""

import functools
from dataclasses import dataclass

from shbake.bakers.shexp import FitConfig, FitPlan
from shbake.batch.plan_cache import cached_dfg_table, cached_fit_plan
from shbake.batch.scheduler import CONNECT_SECONDS, completed, session, write_returned
from shbake.batch.workers import JOBS_LIMIT, start_server, worker_pool
from shbake.envmap import load_environment
from shbake.errors import InputError, ParameterError
from shbake.format.asset import write_asset
from shbake.format.atomic import collected, detached, refuse_same_file
from shbake.format.probe import probe_bytes
from shbake.format.shexp import build_shexp_asset
from shbake.jit import use_one_thread
from shbake.resources import check_memory


@dataclass(frozen=True)
class ProbeJob:
    """One probe: map path → asset path (``None``: return the probe for a set), with the
    fit configuration and input policies."""

    source: str
    output: str | None
    config: FitConfig = FitConfig()
    negative: str = "clamp"
    fix_nonfinite: str | None = None


@functools.lru_cache(maxsize=4)
def fit_plan(config: FitConfig, shape: tuple[int, int]) -> FitPlan:
    """The plan for ``config`` and map ``shape``: once per process, once per machine
    (:mod:`shbake.batch.plan_cache`). Refused above the memory budget before it is built."""
    check_fit_memory(config, shape, 1)
    return cached_fit_plan(config, shape)


@functools.lru_cache(maxsize=1)
def shared_dfg_table():
    """The DFG table, once per process, once per machine (:mod:`shbake.batch.plan_cache`)."""
    return cached_dfg_table()


GATHER_BATCH = 8
"""Probes whose targets are gathered in one pass over the plan (one worker's chunk)."""


def _load(job: ProbeJob):
    env = load_environment(
        job.source, negative=job.negative, fix_nonfinite=job.fix_nonfinite, quiet=True
    )
    if env.layout != "latlong":
        raise InputError(f"{job.source}: probe-fit takes lat-long maps (2:1), got {env.layout}")
    return env


def _finish(job: ProbeJob, env, probe) -> dict:
    from shbake.evaluation.probes import glossy_error  # the headline: against brute force

    asset = build_shexp_asset(probe, job.config, shared_dfg_table(), env.meta)
    summary = {"source": job.source, "output": job.output, "bytes": probe_bytes(asset),
               "error": glossy_error(asset, env)}  # fmt: skip
    if job.output is None:
        return summary | {"p": probe.p, "q": probe.q, "knots": probe.knots, "stats": probe.stats,
                          "meta": env.meta}  # fmt: skip
    with detached():  # each probe of a batch is atomic on its own (docs/FORMAT.md §1)
        write_asset(job.output, asset)
    return summary | probe.stats


def run_probe_job(job: ProbeJob) -> dict:
    """Fit one probe and write it; returns a summary (no timing, for determinism).
    Without an output the summary carries the probe (``p``, ``q``, ``knots``, ``stats``,
    ``meta``)."""
    return run_probe_batch([job])[0]


def run_probe_batch(jobs: list[ProbeJob]) -> list[dict]:
    """Fit several probes, gathering the targets of those that share a configuration and
    map shape in one pass (:meth:`FitPlan.fit_many`); summaries in job order. A probe's
    bytes do not depend on the batch it ran in."""
    envs = [_load(job) for job in jobs]
    groups: dict = {}
    for i, (job, env) in enumerate(zip(jobs, envs, strict=True)):
        groups.setdefault((job.config, env.shape), []).append(i)
    results: list = [None] * len(jobs)
    for (config, shape), members in groups.items():
        check_fit_memory(config, shape, len(members))
        probes = fit_plan(config, shape).fit_many([envs[i].pixels for i in members])
        for i, probe in zip(members, probes, strict=True):
            results[i] = _finish(jobs[i], envs[i], probe)
    return results


def check_fit_memory(config: FitConfig, shape: tuple[int, int], maps: int,
                     workers: int = 1) -> None:  # fmt: skip
    """Refuse, before building the plan, a fit whose :meth:`FitConfig.memory` (times the
    ``workers`` processes that each hold a plan) exceeds the memory budget."""
    h, w = shape
    per = f" in each of {workers} workers" if workers > 1 else ""
    check_memory(
        workers * config.memory(shape, maps),
        f"the probe fit ({config.normals} normals x {config.views} views x "
        f"{config.alpha_count} alphas, {config.samples} samples, {w}x{h} maps{per})",
    )


def _warm_plan_cache(jobs: list[ProbeJob], n_jobs: int = 1) -> None:
    """Build the first job's plan here, on every core, so that workers load it from
    the plan cache instead of each building it (a bad first map is left to its job).
    Refuses a fit whose plans, one per worker, exceed the memory budget."""
    try:
        env = load_environment(jobs[0].source, fix_nonfinite="black", negative="keep", quiet=True)
    except (InputError, ParameterError):
        return
    if env.layout == "latlong":
        check_fit_memory(jobs[0].config, env.shape, min(len(jobs), GATHER_BATCH), n_jobs)
        fit_plan(jobs[0].config, env.shape)
    shared_dfg_table()


def check_jobs(jobs: list[ProbeJob]) -> None:
    """Refuse, before any work, a job whose output is any job's map (same file)."""
    refuse_same_file([j.output for j in jobs if j.output], [j.source for j in jobs])


def run_local(jobs: list[ProbeJob], n_jobs: int = 1, progress=None,
              finished: list | None = None) -> list[dict]:  # fmt: skip
    """Run jobs in this process (``n_jobs = 1``) or ``n_jobs`` worker processes.

    Worker processes (:mod:`shbake.batch.workers`) run numba on one thread each. Results
    keep the job order; ``finished`` (a list) receives each job's summary as soon as it is
    done, so a caller still knows what completed when a later job fails.
    """
    check_jobs(jobs)
    done = finished if finished is not None else []
    if not 1 <= n_jobs <= JOBS_LIMIT:
        raise ParameterError(f"--jobs must be in [1, {JOBS_LIMIT}], got {n_jobs}")
    results = []
    if n_jobs == 1:
        for i in range(0, len(jobs), GATHER_BATCH):
            batch = run_probe_batch(jobs[i : i + GATHER_BATCH])
            results.extend(batch)
            done.extend(batch)
            if progress:
                progress(len(results), len(jobs))
        return results
    start_server()  # it warms while the plan is built or loaded here
    _warm_plan_cache(jobs, n_jobs)
    batches = [jobs[i : i + GATHER_BATCH] for i in range(0, len(jobs), GATHER_BATCH)]
    with worker_pool(n_jobs) as pool:
        for batch in pool.map(run_probe_batch, batches):
            results.extend(batch)
            done.extend(batch)
            if progress:
                progress(len(results), len(jobs))
    return results


def _dask_job(job: ProbeJob) -> tuple[dict, bytes | None]:
    """A Dask worker's probe: its summary and the bytes of its file, which the client writes
    (:mod:`shbake.batch.scheduler`: a worker writes nothing where outputs go)."""
    use_one_thread()
    with collected() as outputs:
        summary = run_probe_job(job)
        return summary, (outputs.read(job.output) if job.output else None)


def run_dask(jobs: list[ProbeJob], scheduler, progress=None, finished: list | None = None,
             connect_timeout: float = CONNECT_SECONDS) -> list[dict]:  # fmt: skip
    """Run jobs on a Dask scheduler (an address, connected within ``connect_timeout``
    seconds, or a connected client, :func:`shbake.batch.scheduler.session`); results keep
    job order (``finished`` as in :func:`run_local`, in completion order). Each probe's
    file is written here as its result arrives, atomic on its own."""
    check_jobs(jobs)
    with session(scheduler, connect_timeout) as client:
        results: list = [None] * len(jobs)
        futures = client.map(_dask_job, jobs, pure=False)
        for done, (i, (summary, data)) in enumerate(completed(client, futures), 1):
            if data is not None:
                with detached():  # each probe of a batch is atomic on its own
                    write_returned(jobs[i].output, data)
            results[i] = summary
            if finished is not None:
                finished.append(summary)
            if progress:
                progress(done, len(jobs))
    return results
