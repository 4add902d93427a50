"""What a worker process loads before its first task: the modules whose functions workers
run and numba's CPU target (:func:`shbake.jit.load_numba`), ~1.3 CPU s that a worker's first
task would otherwise pay.

Imported once in the fork server of :mod:`shbake.batch.workers` (``set_forkserver_preload``),
so that each worker forked from it starts warm, and by a Dask worker started with
``--preload shbake.batch.warm_worker`` (docs/SCENES.md).
"""

import signal


def _warm() -> None:
    import shbake.batch.plan  # noqa: F401  (plan --jobs: _plan_task)
    import shbake.batch.probe_jobs  # noqa: F401  (probe-fit --jobs)
    import shbake.batch.project_many  # noqa: F401  (project-env, split-sum --jobs)
    import shbake.batch.scene_bake  # noqa: F401  (bake --jobs: bake_chunk)
    from shbake.jit import load_numba

    load_numba()


# Ctrl-C reaches the whole process group, the fork server too, which ignores it only once
# this import is done (multiprocessing.forkserver.main): until then it is ignored here, or
# the server prints a KeyboardInterrupt traceback after shbake's one line.
try:
    _saved = signal.signal(signal.SIGINT, signal.SIG_IGN)
except ValueError:  # not the main thread (a Dask preload): nothing to protect
    _warm()
else:
    try:
        _warm()
    finally:
        signal.signal(signal.SIGINT, _saved)
