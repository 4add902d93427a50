"""Explicit SIMD and memory intrinsics for numba kernels: what LLVM would not do alone.

Each name is a plain Python function (the ``py_func`` of a kernel calls it, with the
meaning its docstring gives) and, once numba is loaded, an ``@intrinsic`` of the same
name that lowers to the LLVM construct named in its docstring. A kernel imports them
from here and calls them like functions::

    from shbake.jit import jit
    from shbake.simd import LANES, vload, vsplat, vstore

    @jit
    def scale(x, k, out):  # x, out: C-contiguous float64, size a multiple of LANES
        for i in range(0, x.size, LANES):
            vstore(out, i, vload(x, i) * vsplat(k))

- code attributes: :func:`wide_vectors` (512-bit vectors), :func:`inline_into_callers`
  (LLVM ``alwaysinline``), :func:`disjoint_arrays` (LLVM ``noalias``);
- memory: :func:`stream_store` / :func:`stream_fence` (non-temporal stores),
  :func:`prefetch`, :func:`aligned_empty` (64-byte-aligned scratch);
- time: :func:`clock_ticks` (a tick counter inside kernels);
- explicit vectors of :data:`LANES` doubles: :func:`vload`, :func:`vstore`,
  :func:`vsplat`, :func:`vsum`, :func:`vload_channels` and ``+ - *`` on them, for
  kernels whose state must stay in registers across loops LLVM would not vectorise
  (runtime trip counts inside the per-direction work: the fused SH evaluation,
  :mod:`shbake.sh.basis`) or whose shuffles it would not find (the projection's fold
  of interleaved RGB rows, :mod:`shbake.sh.projection`).

Like every kernel they are check-free: no bounds checks, the caller validated the
arrays. Their numba side is registered through :func:`shbake.jit.on_numba_load`, so
importing this module does not import numba. Tested one by one in ``tests/core/test_simd.py``
(compiled and interpreted against numpy).
"""

import numpy as np

from shbake.jit import jit, on_numba_load


def wide_vectors() -> None:
    """Let the calling kernel's loops use 512-bit vectors where the CPU has them.

    Lowers to the ``"prefer-vector-width"="512"`` attribute on the calling kernel's LLVM
    function; a no-op in Python, ignored on CPUs without AVX-512. For FMA-bound kernels
    whose loops LLVM vectorises itself: its tuning for the Intel cores with AVX-512 prefers
    256-bit vectors, and the SH evaluation runs ~15 % faster with 512
    (docs/BENCHMARKS.md). Memory-bound kernels gain nothing.
    """


def inline_into_callers() -> None:
    """Have LLVM inline the calling kernel into every kernel that calls it; a no-op in Python.

    Lowers to the ``alwaysinline`` attribute on the calling kernel's LLVM function. For a
    helper kernel called from a hot loop with constant arguments (a channel count, a
    flag) that should fold after inlining.

    Numba's own ``inline="always"`` copies the callee's numba IR into each call site
    before typing, which for a large helper called several times costs seconds of
    compile time per copy; LLVM inlines the compiled function instead, after which
    its constant arguments fold as before. The projection's row kernels (4096×2048 RGB
    row sums bit-identical, same speed) compiled in 7.8 s instead of 23.2 s per signature
    once their helpers and the vector operations (:func:`vload` …) were inlined by LLVM.
    """


def disjoint_arrays() -> None:
    """Promise LLVM that the calling kernel's array arguments do not overlap; a no-op in Python.

    Lowers to the ``noalias`` attribute on the data pointers of the calling kernel's LLVM
    function (every pointer argument but byte pointers: numba's reference counts, and
    bool or 8-bit arrays, get none); inlined (:func:`inline_into_callers`), LLVM keeps it
    as scoped alias metadata. Without it LLVM does not vectorise a loop that stores to one
    array and reads another at computed indices (a table look-up: "cannot identify array
    bounds"), as it cannot bound the reads to test for overlap at run time. The callers
    must keep the promise: an array written by the kernel shares no memory with any other
    of its array arguments (read-only arrays may overlap each other).
    """


def stream_store(arr, index, value) -> None:
    """``arr.flat[index] = value`` as a non-temporal (streaming) store in kernels.

    Lowers to a ``store`` with ``!nontemporal`` metadata (``movnt*`` on x86); ``value``
    is cast to ``arr``'s dtype; ``index`` counts elements of the flat, C-contiguous
    ``arr``. For large outputs written once and not read back soon (``evaluate``'s
    values, the stored basis of :mod:`shbake.sh.basis`): the line is not read from memory
    first and not kept in the caches. A kernel that streams must call
    :func:`stream_fence` before it returns. Interpreted: an ordinary store. Check-free
    (no bounds check).
    """
    arr.flat[index] = value


def prefetch(arr, index) -> None:
    """Hint that ``arr.flat[index]`` will be read soon (``llvm.prefetch`` in kernels; a no-op
    in Python). ``index`` counts elements of the flat, C-contiguous ``arr``. Check-free:
    the address is not dereferenced, any index is harmless. For a streaming read whose
    next address the kernel knows but the hardware prefetcher would not guess in time
    (the projection reads rows from both ends of the image).

    Locality 2 (``prefetcht1`` on x86): into the L2 cache, not L1. The projection requests
    a whole row ahead (48 KiB for 4096 RGB float32), more than the 32 KiB L1 holds: into L1
    it evicted the block's table columns and folded values. 4096×2048 RGB row sums,
    streamed, AMD EPYC (Zen 4): lmax 8 15.5–16.5 → 13.6–14.1 ms, lmax 2 10.5 → 10.0;
    locality 1 (L2 as well on that CPU) gave 14.1–14.5 at lmax 8."""


def clock_ticks() -> int:
    """A monotonic tick count for timing parts of a kernel.

    Lowers to ``llvm.readcyclecounter`` (``rdtsc``: the constant-rate time-stamp counter
    on x86); ``time.perf_counter_ns`` in Python. Only differences and ratios of ticks
    mean anything: ticks are not seconds, and the rate differs between machines and
    between the compiled and interpreted kernel. For a kernel that reports where its time
    went without leaving numba (brdf-table's per-view refinement history,
    :mod:`shbake.brdf.tabulate`)."""
    import time

    return time.perf_counter_ns()


def stream_fence() -> None:
    """Order the calling kernel's streaming stores (:func:`stream_store`) before every
    later store, so other threads see them once the kernel returns.

    Lowers to ``llvm.x86.sse.sfence`` on x86, a sequentially consistent ``fence``
    elsewhere; a no-op in Python. Once per kernel call, after its last streaming store."""


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

    Lowers to one ``load <LANES x double>`` (8-byte aligned) into a ``<LANES x double>``
    SSA value (a register), whose ``+``, ``-`` and ``*`` — with another vector or a scalar,
    broadcast — are single vector instructions (``fadd``/``fsub``/``fmul`` with the
    ``contract`` flag, so ``a * b + c`` becomes an FMA). Interpreted: a float64 numpy
    array of ``LANES`` values (numpy's operators, no FMA: results can differ in the last
    bit). For kernels whose per-lane state must stay in registers across inner loops
    LLVM does not vectorise (runtime trip counts). ``index`` counts elements; ``arr``
    must be a C-contiguous float64 array (anything else fails to compile); check-free
    (no bounds check).
    """
    return np.array(arr.reshape(-1)[index : index + LANES], dtype=np.float64)


def vstore(arr, index, vector) -> None:
    """``arr.flat[index : index + LANES] = vector`` (see :func:`vload`).

    Lowers to one ``store <LANES x double>`` (8-byte aligned). ``arr`` C-contiguous
    float64, ``index`` in elements; check-free."""
    arr.reshape(-1)[index : index + LANES] = vector


def vsplat(x):
    """A vector with every lane ``x`` (a float or an integer, converted to float64).

    Lowers to ``insertelement`` + a zero-mask ``shufflevector`` (a broadcast). For a
    vector's starting value or a constant; a scalar operand of ``+ - *`` is broadcast
    the same way without it (see :func:`vload`)."""
    return np.full(LANES, x, dtype=np.float64)


def vsum(vector) -> float:
    """The sum of a vector's lanes.

    Lowers to ``llvm.vector.reduce.fadd`` with the ``reassoc`` flag: a reduction tree,
    whose rounding differs from a left-to-right sum (and from the interpreted
    ``np.sum``) in the last bits. Once per vector accumulator, after its loop."""
    return float(np.sum(vector))


def vload_channels(arr, index, channels, reverse):
    """The ``channels`` interleaved channels of ``LANES`` pixels as a tuple of vectors.

    Reads ``arr.flat[index : index + channels × LANES]`` — pixels of
    ``channels`` values each — once; lane ``L`` of vector ``c`` is channel
    ``c`` of pixel ``L``, or of pixel ``LANES-1-L`` when ``reverse``
    (a run read backwards). float32 values are widened to float64.

    Lowers to one ``load <channels × LANES x float|double>``, one ``shufflevector`` per
    channel (the lane permutation, built at compile time) and, for float32, an
    ``fpext``. For interleaved RGB pixels a kernel works on channel by channel (the
    projection's fold of a row with its mirror image). ``channels`` and ``reverse`` must
    be constants in kernels (literals; a variable fails to compile); ``arr`` is
    C-contiguous float32 or float64, ``index`` in elements. Check-free.
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
    def _noalias(typingctx):
        def codegen(context, builder, signature, args):
            byte = ir.IntType(8)
            for arg in builder.function.args:
                pointee = getattr(arg.type, "pointee", byte)  # opaque pointers: none
                if isinstance(arg.type, ir.PointerType) and pointee != byte:
                    arg.add_attribute("noalias")
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
    overload(disjoint_arrays, inline="always")(lambda: lambda: _noalias())
    overload(stream_store, inline="always")(
        lambda arr, index, value: lambda arr, index, value: _store(arr, index, value)
    )
    overload(stream_fence, inline="always")(lambda: lambda: _fence())


@jit
def aligned_empty(n):
    """``np.empty(n)`` of float64 (``n`` values) starting on a 64-byte boundary.

    A view of an array 8 values longer, offset to the first cache line. For scratch that
    :func:`vload`/:func:`vstore` walk in whole vectors: no vector straddles two cache
    lines (whole AVX-512 loads), which the allocator's 16-byte alignment does not give.
    A kernel (compiled on first call); any kernel may call it."""
    raw = np.empty(n + 8)
    off = ((-raw.ctypes.data) % 64) // 8
    return raw[off : off + n]


def _register() -> None:
    _register_intrinsics()
    _register_vectors()


on_numba_load(_register)
