"""The one numba decorator every kernel uses, and the threads kernels run on.

Kernels are check-free: they assume the caller (a public Python function)
validated shapes, dtypes and ranges, and say so in their docstrings.
``cache=True`` keeps compiled machine code in ``__pycache__`` so a second
process (a ``make -j`` pipeline, a test worker) does not compile again.
``nogil=True`` lets the signal watcher (:mod:`shbake.signals`) and the other
threads of :func:`run_blocks` run while a kernel does. The explicit SIMD and
memory intrinsics kernels call (vectors, streaming stores, prefetch, tick
counter) are in :mod:`shbake.simd`.

Threads (SPEC §6): one model, :func:`run_blocks`. A kernel is a serial ``nogil`` numba
function over a range of *blocks* (``kernel(*args, b0, b1)``); :func:`run_blocks` hands
blocks out a few at a time from a shared counter to at most :func:`thread_count` Python
threads, the caller being one of them. Why not numba's ``prange`` (``parallel=True``),
which 19 kernels used until issue 28:

- the machines have 2 cores shared with other work; ``prange`` splits a loop into equal
  static parts, so one descheduled worker stalls the whole call, while here a worker that
  loses its core simply takes fewer blocks;
- a second thread pool (numba's, beside OpenBLAS's and OpenImageIO's) competes for the
  same 2 cores; these threads exist only while a kernel runs;
- one thread budget (below) covers every kernel: ``numba.set_num_threads`` reached only
  the ``prange`` kernels, so a pool worker's other kernels still took 2 threads
  (:func:`use_one_thread` now limits them all);
- small jobs run on the calling thread alone (starting a thread costs ~50 µs), where
  ``prange`` woke every worker for any size;
- ``parallel=True`` compiles slower: the first calls of the 18 converted public functions
  took 88 s against 48 s from an empty cache (same process, load average 7–12).

Converting them changed no output: each kernel's results are ``np.array_equal`` to the
``prange`` version's (18 representative calls), and so are the brdf-table, split-sum,
shrm, probe-fit and glTF-export outputs. Speed on this 2-core VM, under a load average of
4–13 from other work (A/B in one process, alternating): whole processes split-sum 0.76×,
shrm 0.73×, probe-fit 0.79×, export 0.97×, brdf-table ``--samples`` 1.00×, preview
``tangent`` pass 0.83× the ``prange`` time; single-thread CPU time per kernel 0.92–1.03×.
Two loops needed care: the probe gather allocated its accumulator per target (``prange``
hoists such allocations; now once per call), and :meth:`~shbake.brdf.model.BRDF.evaluate`
passed a view ``out[i]`` per point (its reference counting cost ~5 ns a point; now a
scratch array). ``BRDF.evaluate`` stays ~7 % slower per point single-threaded (AS:
32.5 → 34.7 ms for 500 000 points): numba's ``parallel`` pipeline compiles that loop
into faster code for a reason not found (not the error model, aliasing or the view); it
serves only brdf-table's ``--report`` and tests, so it follows the one model too.
``prange`` compiled its loop bodies with ``error_model="numpy"`` (a float division by zero
gives ``inf``/``nan``); the converted bodies divide only by guarded or non-zero values.

The thread budget is ``SHBAKE_THREADS``, else ``NUMBA_NUM_THREADS``, else the
CPUs this process may run on.
"""

import os
import sys
import threading
from functools import update_wrapper


class LazyKernel:
    """A numba kernel compiled — or loaded from numba's on-disk cache — on its first call.

    Importing a module full of kernels then costs nothing: ``numba`` itself
    (~200 ms) is imported only when a kernel first runs, so a command whose
    options need no kernel (``--help``, a small-``lmax`` bake) never loads
    it. Calls from other kernels work as with a plain dispatcher (numba types
    a ``LazyKernel`` as its dispatcher). ``py_func`` is the Python function.
    """

    def __init__(self, py_func, options: dict):
        update_wrapper(self, py_func)
        self.py_func = py_func
        self._options = options
        self._dispatcher = None
        self._lock = threading.Lock()

    @property
    def dispatcher(self):
        """The ``numba`` dispatcher (created on first use)."""
        if self._dispatcher is None:
            with self._lock:
                if self._dispatcher is None:
                    self._dispatcher = _compile(self.py_func, self._options)
        return self._dispatcher

    def __call__(self, *args):
        return self.dispatcher(*args)

    def __getattr__(self, name):  # signatures, inspect_asm, … of the dispatcher
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.dispatcher, name)

    def __repr__(self) -> str:
        return f"<LazyKernel {self.__qualname__}>"

    def __reduce__(self):  # pickled by reference, like a function (Dask, multiprocessing)
        return (_lookup, (self.__module__, self.__qualname__))


def _lookup(module: str, qualname: str):
    import importlib

    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


_registered = False
_hooks = []


def on_numba_load(register) -> None:
    """Call ``register()`` once numba is loaded: now if it is, else just before the first
    kernel compiles. How :mod:`shbake.simd` defines its ``@intrinsic``/``@overload``
    functions without importing numba (~200 ms) in every process that imports a kernel."""
    if _registered:
        register()
    else:
        _hooks.append(register)


def _register_with_numba():
    global _registered
    if _registered:
        return
    from numba.core import types
    from numba.extending import typeof_impl

    @typeof_impl.register(LazyKernel)
    def _typeof_lazy(val, c):
        return types.Dispatcher(val.dispatcher)

    _registered = True
    for register in _hooks:
        register()
    _hooks.clear()


def load_numba() -> None:
    """Import numba and build its CPU target now (~0.8 s) rather than at the first kernel
    call: in a process whose tasks come later (a fork server, a Dask worker:
    :mod:`shbake.batch.warm_worker`)."""
    from numba.core.registry import cpu_target

    _register_with_numba()
    cpu_target.target_context.refresh()


def _compile(py_func, options: dict):
    import numba

    _register_with_numba()
    return numba.njit(**options)(py_func)


def _decorator(defaults: dict):
    def decorate(fn=None, **options):
        opts = {**defaults, **options}
        if fn is None:
            return lambda f: LazyKernel(f, opts)
        return LazyKernel(fn, opts)

    return decorate


jit = _decorator(dict(cache=True, fastmath=False, nogil=True))
"""``numba.njit`` with ``cache=True`` and ``nogil=True``, lazily compiled: every kernel
(serial; :func:`run_blocks` runs the parallel ones)."""


if "numba" in sys.modules:  # numba already loaded: kernels may meet LazyKernels at once
    _register_with_numba()


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


def use_one_thread() -> None:
    """Run every kernel of this process on its calling thread: for a pool worker, whose
    siblings already keep the other cores busy. Sets ``SHBAKE_THREADS=1`` (inherited by
    any process it starts)."""
    os.environ["SHBAKE_THREADS"] = "1"


def thread_count(work: float, blocks: int) -> int:
    """Threads worth starting for ``work`` units split into ``blocks`` blocks."""
    return int(max(1, min(thread_budget(), blocks, work // MIN_WORK_PER_THREAD)))


def run_blocks(kernel, n_blocks: int, work: float, *args, advance=None) -> None:
    """Call ``kernel(*args, b0, b1)`` over consecutive block ranges covering ``[0, n_blocks)``.

    ``kernel`` must release the GIL (numba ``nogil=True``) and write disjoint
    outputs for disjoint block ranges. Blocks go out in groups of
    ``max(1, n_blocks // (8 × threads))`` to whichever thread is free.
    ``advance(n)``: called (one call at a time) with the number of blocks of each group
    finished — a progress bar's step; with it, one thread also runs in groups.
    """
    threads = thread_count(work, n_blocks)
    if threads == 1 and advance is None:
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
                b1 = min(n_blocks, b0 + step)
                kernel(*args, b0, b1)
                if advance is not None:
                    with lock:
                        advance(b1 - b0)
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
