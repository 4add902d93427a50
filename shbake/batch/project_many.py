"""``project-env`` and ``split-sum`` over many maps in one process or ``--jobs`` workers.

A build that bakes thousands of probes should not start an interpreter per map (its
start-up costs more than a map's projection). :func:`run_many` takes the maps as
arguments and/or a list file (lines ``MAP [OUTPUT]``,
:func:`shbake.batch.map_list.read_map_list`), writes ``OUT_DIR/STEM.h5`` (or the list's
named output) for each, and runs them here or in a pool of workers
(:func:`shbake.batch.workers.worker_pool`), a few maps per task. Every output is
checked before any work (two maps may not write one file, no output may be a map) and
written atomically on its own, as ``probe-fit``'s (docs/FORMAT.md §1): an interrupted
batch keeps the maps it completed. Each output is the one-map command's with the same
settings but for what provenance records of the run (its command line, the map's path
relative to the output).
"""

import os
from contextlib import nullcontext

from shbake.errors import ParameterError
from shbake.format.atomic import (
    detached,
    makedirs,
)
from shbake.resources import path_arguments

TASK_MAPS = 8
"""Maps per worker task (amortises the task's scheduling and the result's transfer)."""


def _project_task(command: str, pairs: list[tuple[str, str]], settings: dict) -> list[dict]:
    """Bake ``pairs`` with ``command``'s library call, each output atomic on its own."""
    if command == "project-env":
        from shbake.batch.project_env import project_environment as bake
    else:
        from shbake.batch.probe_eval import bake_splitsum_file as bake
    out = []
    for src, dst in pairs:
        with detached():
            summary = bake(src, dst, **settings)
        out.append({"input": src, "output": dst, "warnings": summary.get("warnings", [])})
    return out


@path_arguments("pairs")
def run_many(command: str, pairs: list[tuple[str, str]], settings: dict, n_jobs: int = 1,
             progress=None) -> list[dict]:  # fmt: skip
    """Run ``command`` (``project-env``: :func:`~shbake.batch.project_env.project_environment`,
    ``split-sum``: :func:`~shbake.batch.probe_eval.bake_splitsum_file`) on every ``(map,
    output)`` pair with the keyword ``settings`` of that call, here (``n_jobs = 1``) or in
    ``n_jobs`` worker processes, :data:`TASK_MAPS` maps a task; per-map summaries (input,
    output, warnings) in order. ``progress(done, total)``: after each task."""
    from shbake.batch.workers import JOBS_LIMIT, worker_pool

    if not 1 <= n_jobs <= JOBS_LIMIT:
        raise ParameterError(f"--jobs must be in [1, {JOBS_LIMIT}], got {n_jobs}")
    for folder in sorted({os.path.dirname(o) for _, o in pairs}):
        makedirs(folder)
    tasks = [pairs[i : i + TASK_MAPS] for i in range(0, len(pairs), TASK_MAPS)]
    parallel = n_jobs > 1 and len(tasks) > 1
    results: list[dict] = []
    with worker_pool(n_jobs) if parallel else nullcontext() as pool:
        n = len(tasks)
        done = (pool.map(_project_task, [command] * n, tasks, [settings] * n) if parallel
                else (_project_task(command, t, settings) for t in tasks))  # fmt: skip
        for task in done:
            results += task
            if progress:
                progress(len(results), len(pairs))
    return results
