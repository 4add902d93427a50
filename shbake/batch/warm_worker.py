"""What the fork server of :mod:`shbake.batch.workers` loads before it forks a worker.

Imported once, in the server (``set_forkserver_preload``): the modules whose functions
workers run and numba's CPU target (:func:`shbake.jit.load_numba`), so that each worker
starts warm. :data:`SERVER_PID` is the server's process id, which every worker inherits:
the parent whose exit ends the worker (:func:`shbake.signals.worker_init`).
"""

import os

import shbake.batch.plan  # noqa: F401  (plan --jobs: _plan_task)
import shbake.batch.probe_jobs  # noqa: F401  (probe-fit --jobs)
import shbake.batch.project_many  # noqa: F401  (project-env, split-sum --jobs)
import shbake.batch.scene_bake  # noqa: F401  (bake --jobs: bake_chunk)
from shbake.jit import load_numba

SERVER_PID = os.getpid()

load_numba()
