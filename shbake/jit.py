"""The one numba decorator every kernel uses, and the few intrinsics kernels call.

Intrinsics (no-ops or plain Python when interpreted): :func:`wide_vectors` (512-bit
vectors), :func:`inline_into_callers` (LLVM inlining of a helper), :func:`stream_store`
/ :func:`stream_fence` (non-temporal stores), :func:`prefetch`, :func:`clock_ticks` (a
tick counter for timing inside kernels), and explicit vectors of :data:`LANES` doubles —
:func:`vload`, :func:`vstore`, :func:`vsplat`, :func:`vsum`, :func:`vload_channels`
(split interleaved float32/float64 pixels into per-channel vectors, optionally in
reversed pixel order) and ``+ - *`` on them — for kernels whose state must stay in
registers across loops LLVM would not vectorise (runtime trip counts inside the
per-direction work) or whose shuffles it would not find. They are registered with numba
when it is first loaded. :func:`aligned_empty` gives 64-byte-aligned scratch.

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
import sys
import threading
from functools import update_wrapper

import numpy as np

prange = range
"""Use ``from shbake.jit import prange`` in :data:`pjit` kernels: it becomes ``numba.prange``
when the kernel is compiled and stays ``range`` for the interpreted ``py_func``."""


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


def wide_vectors() -> None:
    """Let the calling kernel's loops use 512-bit vectors where the CPU has them.

    LLVM's tuning for the Intel cores with AVX-512 prefers 256-bit vectors;
    the FMA-bound SH evaluation runs ~15 % faster with 512 (docs/BENCHMARKS.md).
    Sets the ``"prefer-vector-width"="512"`` attribute on the kernel; a no-op
    in Python, ignored on CPUs without AVX-512.
    """


def inline_into_callers() -> None:
    """Have LLVM inline the calling kernel into every kernel that calls it (the
    ``alwaysinline`` attribute); a no-op in Python.

    Numba's own ``inline="always"`` copies the callee's numba IR into each call site
    before typing, which for a large helper called several times costs seconds of
    compile time per copy; LLVM inlines the compiled function instead, after which
    its constant arguments fold as before. The projection's row kernels (4096×2048 RGB
    row sums bit-identical, same speed) compiled in 7.8 s instead of 23.2 s per signature
    once their helpers and the vector operations (:func:`vload` …) were inlined by LLVM.
    """


def stream_store(arr, index, value) -> None:
    """``arr.flat[index] = value`` as a non-temporal (streaming) store in kernels.

    For outputs written once and not read back soon: the line is not read
    from memory first and not kept in the caches. A kernel that streams must
    call :func:`stream_fence` before it returns. Check-free (no bounds check).
    """
    arr.flat[index] = value


def prefetch(arr, index) -> None:
    """Hint that ``arr.flat[index]`` will be read soon (``llvm.prefetch`` in kernels; a no-op
    in Python). Check-free: the address is not dereferenced, any index is harmless.

    Locality 2 (``prefetcht1`` on x86): into the L2 cache, not L1. The projection requests
    a whole row ahead (48 KiB for 4096 RGB float32), more than the 32 KiB L1 holds: into L1
    it evicted the block's table columns and folded values. 4096×2048 RGB row sums,
    streamed, AMD EPYC (Zen 4): lmax 8 15.5–16.5 → 13.6–14.1 ms, lmax 2 10.5 → 10.0;
    locality 1 (L2 as well on that CPU) gave 14.1–14.5 at lmax 8."""


def clock_ticks() -> int:
    """A monotonic tick count for timing parts of a kernel (``llvm.readcyclecounter``: the
    constant-rate time-stamp counter on x86; ``time.perf_counter_ns`` in Python). Only
    differences and ratios of ticks mean anything; ticks are not seconds."""
    import time

    return time.perf_counter_ns()


def stream_fence() -> None:
    """Order the calling kernel's streaming stores before its later stores (``sfence``)."""


def _host_has_avx512() -> bool:
    """Whether this CPU runs AVX-512 (numpy's run-time feature table; ``False`` if absent)."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:  # pragma: no cover - another numpy layout
        return False
    return bool(__cpu_features__.get("AVX512F", False))


LANES = 16 if _host_has_avx512() else 4
"""Doubles in one explicit vector (:func:`vload`), chosen for this CPU's register file so
that the projection's 3 × 4 register tile (12 accumulators and 4 operands, 16 vectors) just
fits it: with AVX-512, 16 — two of its 32 zmm registers, so each vector operation is two
independent instructions and a recurrence keeps both FMA units busy (the fused SH
evaluation at lmax 8 / 30 ran 1.32× / 1.10× faster than with 8); otherwise (AVX2: 16 ymm
registers) 4, one register. On an AVX2-only AMD EPYC, 4096×2048 RGB lmax 8 row sums took
16.0 ms with 4 lanes against 20.5 with 8 and 39 with 16 (spilled tiles); ``evaluate`` at
lmax 8 took 50.0 / 46.8 / 64.1 ms (docs/BENCHMARKS.md). Results differ between widths only
in summation order (~1e-16 relative). A numba target other than the host
(``NUMBA_CPU_NAME``) still gets this CPU's width: correct, perhaps slower."""


def vload(arr, index):
    """``arr.flat[index : index + LANES]`` as one vector (a copy).

    In kernels: a ``<LANES x double>`` SSA value (a register), whose ``+``,
    ``-`` and ``*`` — with another vector or a scalar, broadcast — are single
    vector instructions, and ``a * b + c`` contracts into an FMA. Interpreted:
    a float64 numpy array of ``LANES`` values (numpy's operators, no FMA:
    results can differ in the last bit). ``arr`` must be a C-contiguous
    float64 array; check-free (no bounds check).
    """
    return np.array(arr.reshape(-1)[index : index + LANES], dtype=np.float64)


def vstore(arr, index, vector) -> None:
    """``arr.flat[index : index + LANES] = vector`` (see :func:`vload`). Check-free."""
    arr.reshape(-1)[index : index + LANES] = vector


def vsplat(x):
    """A vector with every lane ``x`` (see :func:`vload`)."""
    return np.full(LANES, x, dtype=np.float64)


def vsum(vector) -> float:
    """The sum of a vector's lanes (any order: a reduction tree in kernels)."""
    return float(np.sum(vector))


def vload_channels(arr, index, channels, reverse):
    """The ``channels`` interleaved channels of ``LANES`` pixels as a tuple of vectors.

    Reads ``arr.flat[index : index + channels × LANES]`` — pixels of
    ``channels`` values each — once; lane ``L`` of vector ``c`` is channel
    ``c`` of pixel ``L``, or of pixel ``LANES-1-L`` when ``reverse``
    (a run read backwards). float32 values are widened to float64.
    ``channels`` and ``reverse`` must be constants in kernels (the lane
    permutation is built at compile time); ``arr`` is C-contiguous float32 or
    float64. Check-free.
    """
    px = np.asarray(arr).reshape(-1)[index : index + channels * LANES].reshape(LANES, channels)
    if reverse:
        px = px[::-1]
    return tuple(px[:, c].astype(np.float64) for c in range(channels))


def _register_vectors():
    """The numba side of :func:`vload`: a type, its LLVM model and its operators."""
    import operator

    from llvmlite import ir
    from numba.core import cgutils, types
    from numba.extending import intrinsic, models, overload, register_model

    class DoubleVector(types.Type):
        def __init__(self):
            super().__init__(name=f"f64x{LANES}")

    vec = DoubleVector()
    llvm_vec = ir.VectorType(ir.DoubleType(), LANES)

    @register_model(DoubleVector)
    class _DoubleVectorModel(models.PrimitiveModel):
        def __init__(self, dmm, fe_type):
            super().__init__(dmm, fe_type, llvm_vec)

    def element_pointer(context, builder, aryty, ary, index):
        data = context.make_array(aryty)(context, builder, ary).data
        return builder.bitcast(builder.gep(data, [index]), llvm_vec.as_pointer())

    def splat(context, builder, ty, x):
        x = context.cast(builder, x, ty, types.float64)
        one = builder.insert_element(ir.Constant(llvm_vec, ir.Undefined), x, ir.IntType(32)(0))
        zeros = ir.Constant(ir.VectorType(ir.IntType(32), LANES), [0] * LANES)
        return builder.shuffle_vector(one, ir.Constant(llvm_vec, ir.Undefined), zeros)

    def is_f64_array(t):  # flat offsets from .data hold for C-contiguous arrays only
        return isinstance(t, types.Array) and t.dtype == types.float64 and t.layout == "C"

    @intrinsic
    def _vload(typingctx, arr, index):
        if not is_f64_array(arr):
            return None

        def codegen(context, builder, sig, args):
            return builder.load(element_pointer(context, builder, sig.args[0], *args), align=8)

        return vec(arr, index), codegen

    @intrinsic
    def _vstore(typingctx, arr, index, vector):
        if not is_f64_array(arr) or vector != vec:
            return None

        def codegen(context, builder, sig, args):
            ptr = element_pointer(context, builder, sig.args[0], args[0], args[1])
            builder.store(args[2], ptr, align=8)
            return context.get_dummy_value()

        return types.void(arr, index, vector), codegen

    @intrinsic
    def _vsplat(typingctx, x):
        if not isinstance(x, (types.Float, types.Integer)):
            return None

        def codegen(context, builder, sig, args):
            return splat(context, builder, sig.args[0], args[0])

        return vec(x), codegen

    def binary(instruction):
        @intrinsic
        def op(typingctx, a, b):
            def codegen(context, builder, sig, args):
                x, y = (
                    v if t == vec else splat(context, builder, t, v)
                    for t, v in zip(sig.args, args, strict=True)
                )
                return getattr(builder, instruction)(x, y, flags=("contract",))

            return vec(a, b), codegen

        def typer(a, b):
            scalar = (types.Float, types.Integer)
            if (a == vec and (b == vec or isinstance(b, scalar))) or (
                b == vec and isinstance(a, scalar)
            ):
                return lambda a, b: op(a, b)

        return typer

    for pyop, instruction in (
        (operator.add, "fadd"),
        (operator.sub, "fsub"),
        (operator.mul, "fmul"),
    ):
        overload(pyop)(binary(instruction))
    overload(vload)(lambda arr, index: lambda arr, index: _vload(arr, index))
    overload(vstore)(
        lambda arr, index, vector: lambda arr, index, vector: _vstore(arr, index, vector)
    )
    overload(vsplat)(lambda x: lambda x: _vsplat(x))

    @intrinsic
    def _vsum(typingctx, vector):
        if vector != vec:
            return None

        def codegen(context, builder, sig, args):
            fnty = ir.FunctionType(ir.DoubleType(), [ir.DoubleType(), llvm_vec])
            name = f"llvm.vector.reduce.fadd.v{LANES}f64"
            fn = cgutils.get_or_insert_function(builder.module, fnty, name)
            return builder.call(fn, [ir.DoubleType()(0.0), args[0]], fastmath=("reassoc",))

        return types.float64(vector), codegen

    overload(vsum)(lambda vector: lambda vector: _vsum(vector))

    def channels_loader(n, reverse):
        @intrinsic
        def load(typingctx, arr, index):
            if not (
                isinstance(arr, types.Array)
                and arr.layout == "C"
                and arr.dtype in (types.float32, types.float64)
            ):
                return None

            def codegen(context, builder, sig, args):
                aryty = sig.args[0]
                elt = context.get_data_type(aryty.dtype)
                block_ty = ir.VectorType(elt, n * LANES)
                data = context.make_array(aryty)(context, builder, args[0]).data
                ptr = builder.bitcast(builder.gep(data, [args[1]]), block_ty.as_pointer())
                block = builder.load(ptr, align=aryty.dtype.bitwidth // 8)
                out = []
                for c in range(n):
                    pixels = range(LANES - 1, -1, -1) if reverse else range(LANES)
                    lanes = [n * p + c for p in pixels]
                    mask = ir.Constant(ir.VectorType(ir.IntType(32), LANES), lanes)
                    v = builder.shuffle_vector(block, ir.Constant(block_ty, ir.Undefined), mask)
                    if aryty.dtype == types.float32:
                        v = builder.fpext(v, llvm_vec)
                    out.append(v)
                return context.make_tuple(builder, sig.return_type, out)

            return types.UniTuple(vec, n)(arr, index), codegen

        return load

    loaders = {}

    @overload(vload_channels, prefer_literal=True)
    def _vload_channels(arr, index, channels, reverse):
        if not isinstance(channels, types.IntegerLiteral) or not isinstance(
            reverse, types.BooleanLiteral
        ):
            return None
        key = (channels.literal_value, reverse.literal_value)
        if key not in loaders:
            loaders[key] = channels_loader(*key)
        load = loaders[key]
        return lambda arr, index, channels, reverse: load(arr, index)


def _register_intrinsics():
    import platform

    from llvmlite import ir
    from numba.core import cgutils, types
    from numba.extending import intrinsic, overload

    @intrinsic
    def _wide(typingctx):
        def codegen(context, builder, signature, args):
            # a string attribute: llvmlite's FunctionAttributes.add accepts only enum ones
            set.add(builder.function.attributes, '"prefer-vector-width"="512"')
            return context.get_dummy_value()

        return types.void(), codegen

    @intrinsic
    def _always_inline(typingctx):
        def codegen(context, builder, signature, args):
            builder.function.attributes.add("alwaysinline")
            return context.get_dummy_value()

        return types.void(), codegen

    @intrinsic
    def _store(typingctx, arr, index, value):
        def codegen(context, builder, signature, args):
            aryty = signature.args[0]
            array = context.make_array(aryty)(context, builder, args[0])
            v = context.cast(builder, args[2], signature.args[2], aryty.dtype)
            st = builder.store(v, builder.gep(array.data, [args[1]]))
            st.set_metadata("nontemporal", builder.module.add_metadata([ir.IntType(32)(1)]))
            return context.get_dummy_value()

        return types.void(arr, index, value), codegen

    @intrinsic
    def _fence(typingctx):
        def codegen(context, builder, signature, args):
            if platform.machine() in ("x86_64", "AMD64"):
                fnty = ir.FunctionType(ir.VoidType(), [])
                sfence = cgutils.get_or_insert_function(builder.module, fnty, "llvm.x86.sse.sfence")
                builder.call(sfence, [])
            else:
                builder.fence("seq_cst")
            return context.get_dummy_value()

        return types.void(), codegen

    @intrinsic
    def _prefetch(typingctx, arr, index):
        def codegen(context, builder, signature, args):
            array = context.make_array(signature.args[0])(context, builder, args[0])
            ptr = builder.bitcast(builder.gep(array.data, [args[1]]), ir.IntType(8).as_pointer())
            i32 = ir.IntType(32)
            fnty = ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32])
            fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch")
            builder.call(fn, [ptr, i32(0), i32(2), i32(1)])
            return context.get_dummy_value()

        return types.void(arr, index), codegen

    @intrinsic
    def _ticks(typingctx):
        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(ir.IntType(64), [])
            fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.readcyclecounter")
            return builder.call(fn, [])

        return types.int64(), codegen

    overload(clock_ticks, inline="always")(lambda: lambda: _ticks())
    overload(prefetch, inline="always")(lambda arr, index: lambda arr, index: _prefetch(arr, index))
    overload(wide_vectors, inline="always")(lambda: lambda: _wide())
    overload(inline_into_callers, inline="always")(lambda: lambda: _always_inline())
    overload(stream_store, inline="always")(
        lambda arr, index, value: lambda arr, index, value: _store(arr, index, value)
    )
    overload(stream_fence, inline="always")(lambda: lambda: _fence())


_registered = False


def _register_with_numba():
    global _registered
    if _registered:
        return
    from numba.core import types
    from numba.extending import typeof_impl

    @typeof_impl.register(LazyKernel)
    def _typeof_lazy(val, c):
        return types.Dispatcher(val.dispatcher)

    _register_intrinsics()
    _register_vectors()
    _registered = True


def _compile(py_func, options: dict):
    import numba

    _register_with_numba()
    g = py_func.__globals__
    if g.get("prange") is range and "prange" in py_func.__code__.co_names:
        g["prange"] = numba.prange  # the module's kernels are compiled from now on
    return numba.njit(**options)(py_func)


def _decorator(defaults: dict):
    def decorate(fn=None, **options):
        opts = {**defaults, **options}
        if fn is None:
            return lambda f: LazyKernel(f, opts)
        return LazyKernel(fn, opts)

    return decorate


jit = _decorator(dict(cache=True, fastmath=False, nogil=True))
"""``numba.njit`` with ``cache=True``, lazily compiled; serial kernels."""

pjit = _decorator(dict(cache=True, fastmath=False, nogil=True, parallel=True))
"""``numba.njit`` with ``cache=True`` and ``parallel=True``, lazily compiled; ``prange`` kernels."""


@jit
def aligned_empty(n):
    """``np.empty(n)`` of float64 starting on a 64-byte boundary (whole cache lines, whole
    AVX-512 loads); a view of a slightly larger array."""
    raw = np.empty(n + 8)
    off = ((-raw.ctypes.data) % 64) // 8
    return raw[off : off + n]


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
