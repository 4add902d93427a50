"""Local worker processes (``--jobs``): pools whose workers fork from a warm server.

A worker started from nothing (multiprocessing's ``spawn``) imports shbake and builds
numba's CPU target before its first task: ~1.3 CPU s (imports 0.5 s, numba 0.24 s, the
target 0.54 s, measured on the 2-core benchmark machine), paid by every worker of every
command. Here the workers fork from multiprocessing's *fork server*, a fresh interpreter
that does that once (:mod:`shbake.batch.warm_worker`): :func:`start_server` starts it as
soon as a command knows it will use workers, so that it warms on the idle core while the
command still hashes its maps or writes its stamps, and each :func:`worker_pool` forks its
workers from it, warm. The server is not a fork of the command: it holds none of the
command's threads, open files or transactions.

Each worker (:func:`_start_worker`) takes the command's working folder and environment at
the pool's start (the server's are those of its own start), runs numba on one thread,
ignores SIGINT and dies with the command, however the command ends (``kill -9`` included):
the worker closes its copy of the server's "alive" pipe, so the server exits as soon as the
command has (multiprocessing's own rule: the server lives while a holder of that pipe does),
and the worker asks Linux for SIGTERM when the server exits (``PR_SET_PDEATHSIG``,
:func:`shbake.signals.worker_init`), which removes its temporaries and ends it.
"""

import contextlib
import multiprocessing
import multiprocessing.forkserver
import multiprocessing.util
import os
from concurrent.futures import ProcessPoolExecutor

from shbake import signals
from shbake.jit import use_one_thread

JOBS_LIMIT = (os.cpu_count() or 1) * 4
"""Most local worker processes (``--jobs``): four per CPU."""

WARM_MODULE = "shbake.batch.warm_worker"
"""The module the fork server imports before it forks a worker."""

STOP_SECONDS = 5.0
"""How long a stopped pool's workers have to remove their temporaries and exit."""


def _context():
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([WARM_MODULE])
    return context


SOCKET_PATH_BYTES = 108
"""Size of a Unix socket's path on Linux (``sun_path``), its final NUL included."""
SOCKET_IN_TEMP = os.path.join("pymp-xxxxxxxx", "listener-xxxxxxxx")
"""Where multiprocessing puts the fork server's socket, relative to ``$TMPDIR``."""


def start_server() -> None:
    """Start the fork server now, if it is not running, without waiting for it to warm:
    :func:`worker_pool` waits when it forks the first worker. Its socket goes in a
    ``pymp-*`` folder of ``$TMPDIR``, or of ``/tmp`` when ``$TMPDIR`` is too long a path
    for a Unix socket (:data:`SOCKET_PATH_BYTES`)."""
    import tempfile

    _context()
    socket = os.path.join(tempfile.gettempdir(), SOCKET_IN_TEMP)
    if len(os.fsencode(socket)) >= SOCKET_PATH_BYTES:
        saved, tempfile.tempdir = tempfile.tempdir, "/tmp"
        try:
            multiprocessing.util.get_temp_dir()  # made now, removed at exit (stop_server)
        finally:
            tempfile.tempdir = saved
    multiprocessing.forkserver.ensure_running()


def stop_server() -> None:
    """Stop the fork server this process started, if any, and wait for it: it exits once
    its workers have, and its CPU time, its workers' included, is then counted as this
    process's children's (``time``, ``getrusage``) like spawned workers' was. Then run
    multiprocessing's exit steps, which the command line's ``os._exit`` would skip: they
    remove the folder of the server's socket (``$TMPDIR/pymp-*``). The command line calls
    it before it exits."""
    multiprocessing.forkserver._forkserver._stop()
    multiprocessing.util._exit_function()


def _start_worker(folder: str, environment: dict, server_pid: int) -> None:
    """Initialiser of a pool's workers (module docstring); ``server_pid``: the fork server's
    process id, the parent whose exit ends the worker."""
    os.chdir(folder)
    os.environ.clear()
    os.environ.update(environment)
    server = multiprocessing.forkserver._forkserver  # set by the server for its children
    if server._forkserver_alive_fd is not None:
        os.close(server._forkserver_alive_fd)
        server._forkserver_alive_fd = None
    signals.worker_init(parent=server_pid)
    use_one_thread()


class _Pool(ProcessPoolExecutor):
    """A process pool whose ``map`` leaves the jobs it did not return to the pool's stop.

    The standard ``map``, left by an exception raised while it waits for a result (SIGINT,
    SIGTERM), cancels its pending jobs in the caller's thread. When the workers then die
    (:func:`worker_pool` terminates them; a signal to the process group kills them), the
    pool's manager thread fails every job it holds, cancelled ones included: CPython 3.11
    raises ``InvalidStateError`` there, printed as ``Exception in thread`` on the command's
    stderr, and the pool's threads are left waiting. Here only the manager thread ends jobs,
    one at a time: it fails them when a worker dies, or cancels them at
    ``shutdown(cancel_futures=True)``."""

    def map(self, fn, *iterables):
        """``fn`` applied to the items of ``iterables`` taken together, in the workers; an
        iterator over the results, in order. Every job is submitted now."""
        futures = [self.submit(fn, *args) for args in zip(*iterables, strict=True)]
        futures.reverse()
        return (futures.pop().result() for _ in range(len(futures)))


@contextlib.contextmanager
def worker_pool(n_jobs: int):
    """A pool of ``n_jobs`` workers forked from the warm server (module docstring). When the
    block fails or is interrupted, the workers are sent SIGTERM at once — each removes its
    temporaries and exits — instead of finishing their current jobs."""
    start_server()
    server_pid = multiprocessing.forkserver._forkserver._forkserver_pid
    pool = _Pool(n_jobs, mp_context=_context(), initializer=_start_worker,
                               initargs=(os.getcwd(), dict(os.environ), server_pid))  # fmt: skip
    try:
        yield pool
    except BaseException:
        workers = list((getattr(pool, "_processes", None) or {}).values())
        for w in workers:
            with contextlib.suppress(OSError, ValueError):
                w.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        for w in workers:
            with contextlib.suppress(OSError, ValueError, AssertionError):
                w.join(STOP_SECONDS)
        raise
    pool.shutdown(wait=True)
