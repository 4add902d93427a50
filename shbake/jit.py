"""The one numba decorator every kernel uses.

Kernels are check-free: they assume the caller (a public Python function)
validated shapes, dtypes and ranges, and say so in their docstrings.
``cache=True`` keeps compiled machine code in ``__pycache__`` so a second
process (a ``make -j`` pipeline, a test worker) does not compile again.

Threads (SPEC §6). The machines have 2 cores shared with other work; numba's ``prange`` splits
a loop into equal static parts, so one descheduled worker stalls the whole
call, and a second busy-waiting pool (BLAS, OpenMP) can make 2 threads slower
than 1. The kernels here instead run as serial, ``nogil`` numba functions over
a range of *blocks*; :func:`run_blocks` hands blocks out one at a time from a
shared counter to at most :func:`thread_count` Python threads (the caller is
one of them). A worker that loses its core simply takes fewer blocks. Small
jobs run on the calling thread alone: starting a thread costs ~50 µs.

The thread budget is ``SHBAKE_THREADS``, else ``NUMBA_NUM_THREADS``, else the
CPUs this process may run on.
"""

import os
import threading
from functools import partial

import numba

jit = partial(numba.njit, cache=True, fastmath=False, nogil=True)
"""``numba.njit`` with ``cache=True``; serial kernels."""

pjit = partial(numba.njit, cache=True, fastmath=False, nogil=True, parallel=True)
"""``numba.njit`` with ``cache=True`` and ``parallel=True``; kernels with ``prange``."""


MIN_WORK_PER_THREAD = 2_000_000
"""Work units (≈ flops or bytes read) below which an extra thread does not pay."""


def thread_budget() -> int:
    """Threads the kernels may use: ``SHBAKE_THREADS`` > ``NUMBA_NUM_THREADS`` > CPU affinity."""
    for var in ("SHBAKE_THREADS", "NUMBA_NUM_THREADS"):
        v = os.environ.get(var)
        if v:
            try:
                return max(1, int(v))
            except ValueError:
                pass
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def thread_count(work: float, blocks: int) -> int:
    """Threads worth starting for ``work`` units split into ``blocks`` blocks."""
    return int(max(1, min(thread_budget(), blocks, work // MIN_WORK_PER_THREAD)))


def run_blocks(kernel, n_blocks: int, work: float, *args) -> None:
    """Call ``kernel(*args, b0, b1)`` over consecutive block ranges covering ``[0, n_blocks)``.

    ``kernel`` must release the GIL (numba ``nogil=True``) and write disjoint
    outputs for disjoint block ranges. Blocks go out in groups of
    ``max(1, n_blocks // (8 × threads))`` to whichever thread is free.
    """
    threads = thread_count(work, n_blocks)
    if threads == 1:
        kernel(*args, 0, n_blocks)
        return
    step = max(1, n_blocks // (8 * threads))
    lock = threading.Lock()
    state = [0]
    errors = []

    def worker():
        try:
            while True:
                with lock:
                    b0 = state[0]
                    state[0] = b0 + step
                if b0 >= n_blocks:
                    return
                kernel(*args, b0, min(n_blocks, b0 + step))
        except BaseException as e:  # pragma: no cover - re-raised below
            errors.append(e)

    pool = [threading.Thread(target=worker, daemon=True) for _ in range(threads - 1)]
    for t in pool:
        t.start()
    worker()
    for t in pool:
        t.join()
    if errors:
        raise errors[0]
