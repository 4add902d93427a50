"""The kernel intrinsics of ``shbake/simd.py``, each compiled in a small kernel and
interpreted, against numpy (values) or the LLVM IR numba generated (attributes, hints)."""

import re

import numpy as np
import pytest

from shbake.jit import jit
from shbake.simd import (
    LANES,
    aligned_empty,
    clock_ticks,
    disjoint_arrays,
    inline_into_callers,
    prefetch,
    stream_fence,
    stream_store,
    vload,
    vload_channels,
    vsplat,
    vstore,
    vsum,
    wide_vectors,
)


@jit
def _store_all(out, values):
    wide_vectors()
    for i in range(values.size):
        stream_store(out, i, values[i])
    stream_fence()


@jit
def _ticks(n, spin):
    t = np.empty(n, np.int64)
    x = 0.0
    for i in range(n):
        for _ in range(spin):
            x = x * 0.5 + 1.0
        t[i] = clock_ticks()
    return t, x


@jit
def _prefetch_anywhere(a):
    s = 0.0
    for i in range(a.size):
        prefetch(a, i + 1_000_000)  # far beyond the end: a hint, never a read
        prefetch(a, i - 1_000_000)
        s += a[i]
    return s


@jit
def _horner_vectors(x, coeffs, out):
    """``out = Σ_k coeffs[k] x^k`` by Horner, ``LANES`` values per vector; a runtime-length
    loop inside the vector loop (what the explicit vectors are for)."""
    n = coeffs.size
    for i in range(0, x.size, LANES):
        v = vload(x, i)
        acc = vsplat(coeffs[n - 1])
        for k in range(n - 2, -1, -1):
            acc = acc * v + coeffs[k]
        vstore(out, i, acc)


@jit
def _mixed_operators(a, b, out):
    u = vload(a, 0)
    w = vload(b, 0)
    vstore(out, 0, u + w)
    vstore(out, LANES, u - w)
    vstore(out, 2 * LANES, u * w)
    vstore(out, 3 * LANES, 2.0 * u - w * 3 + vsplat(1))
    vstore(out, 4 * LANES, 1.5 - u)


@jit
def _split_rgb(img, index, out):
    """The three channels of ``LANES`` pixels from flat ``index``, forwards and reversed,
    into ``out[0:3]`` / ``out[3:6]``; returns the lane sums of the forward red and the
    reversed blue."""
    r, g, b = vload_channels(img, index, 3, False)
    x, y, z = vload_channels(img, index, 3, True)
    for k, v in enumerate((r, g, b, x, y, z)):
        vstore(out, k * LANES, v)
    return vsum(r), vsum(z)


@jit
def _split_one(img, index, out):
    (v,) = vload_channels(img, index, 1, True)
    vstore(out, 0, v)


@jit
def _channels_from_a_variable(img, n, out):
    (v,) = vload_channels(img, 0, n, False)
    vstore(out, 0, v)


def _llvm_ir(kernel, *args) -> str:
    """The LLVM IR of ``kernel`` (compiled without the on-disk cache: cached code cannot
    be inspected) after one call."""
    kernel(*args)
    (ir,) = kernel.inspect_llvm().values()
    return ir


@jit(cache=False)
def _sum_wide(x):
    wide_vectors()
    s = 0.0
    for i in range(x.size):
        s += x[i]
    return s


@jit(cache=False)
def _cube(x):
    inline_into_callers()
    return x * x * x


@jit
def _cubes(a, out):
    for i in range(a.size):
        out[i] = _cube(a[i])


@jit(cache=False)
def _streamed_copy(a, out):
    for i in range(a.size):
        stream_store(out, i, a[i])
    stream_fence()


@jit(cache=False)
def _prefetched_sum(a):
    s = 0.0
    for i in range(a.size):
        prefetch(a, i + 64)
        s += a[i]
    return s


@jit(cache=False)
def _tick():
    return clock_ticks()


@jit
def _splats(x, out):
    vstore(out, 0, vsplat(x))
    vstore(out, LANES, vsplat(3))  # an integer, converted


@jit
def _lane_sums(a, out):
    for k in range(a.size // LANES):
        out[k] = vsum(vload(a, k * LANES))


@jit(cache=False)
def _look_up(table, keys, out):
    disjoint_arrays()
    for i in range(keys.size):
        out[i] = table[keys[i]] * 2.0


class TestAttributesAndHints:
    """Each intrinsic lowers to the LLVM construct its docstring names."""

    def test_wide_vectors_sets_the_vector_width_attribute(self):
        x = np.arange(100.0)
        assert '"prefer-vector-width"="512"' in _llvm_ir(_sum_wide, x)
        assert _sum_wide.py_func(x) == _sum_wide(x) == x.sum()

    def test_inline_into_callers_marks_the_callee_and_keeps_values(self):
        assert "alwaysinline" in _llvm_ir(_cube, 2.0)
        assert "alwaysinline" not in _llvm_ir(_sum_wide, np.ones(3))
        a = np.linspace(-2.0, 2.0, 33)
        out = np.empty_like(a)
        _cubes(a, out)
        np.testing.assert_array_equal(out, a * a * a)
        assert _cube.py_func(3.0) == 27.0

    def test_disjoint_arrays_marks_data_pointers_noalias_and_keeps_values(self):
        table, keys, out = np.arange(5.0), np.array([4, 0, 2, 2]), np.empty(4)
        ir = _llvm_ir(_look_up, table, keys, out)
        define = next(
            line for line in ir.splitlines() if line.startswith("define") and "%arg." in line
        )
        params = {m[2]: m[1] for m in re.finditer(r"(?:ptr|\*)([^,%]*)%(arg\.\w+\.\d)\b", define)}
        for name in ("table", "keys", "out"):  # data pointers, not the reference counts
            assert "noalias" in params[f"arg.{name}.4"]
            assert "noalias" not in params[f"arg.{name}.0"] + params[f"arg.{name}.1"]
        _look_up(table, keys, out)
        np.testing.assert_array_equal(out, [8.0, 0.0, 4.0, 4.0])
        _look_up.py_func(table, keys, out)
        np.testing.assert_array_equal(out, [8.0, 0.0, 4.0, 4.0])

    def test_stream_store_is_nontemporal_and_fenced(self):
        ir = _llvm_ir(_streamed_copy, np.ones(4), np.empty(4))
        assert "!nontemporal" in ir
        assert ("llvm.x86.sse.sfence" in ir) or ("fence seq_cst" in ir)

    def test_prefetch_and_clock_ticks_lower_to_their_llvm_intrinsics(self):
        assert "llvm.prefetch" in _llvm_ir(_prefetched_sum, np.ones(8))
        assert "llvm.readcyclecounter" in _llvm_ir(_tick)
        assert isinstance(_tick(), int)


class TestSplatAndSum:
    def test_vsplat_broadcasts_floats_and_integers(self):
        for fn in (_splats, _splats.py_func):
            out = np.zeros(2 * LANES)
            fn(2.5, out)
            np.testing.assert_array_equal(out, [2.5] * LANES + [3.0] * LANES)

    def test_vsum_adds_the_lanes(self):
        a = np.random.default_rng(6).normal(size=5 * LANES)
        ref = a.reshape(5, LANES).sum(axis=1)
        for fn in (_lane_sums, _lane_sums.py_func):
            out = np.zeros(5)
            fn(a, out)
            np.testing.assert_allclose(out, ref, rtol=1e-15, atol=1e-15)
        exact = np.arange(float(LANES))  # small integers: every order sums exactly
        out = np.zeros(1)
        _lane_sums(exact, out)
        assert out[0] == LANES * (LANES - 1) / 2


class TestVectors:
    def test_horner_matches_numpy_polyval(self):
        rng = np.random.default_rng(3)
        x = rng.uniform(-1.0, 1.0, 4 * LANES)
        coeffs = rng.normal(size=9)
        ref = np.polynomial.polynomial.polyval(x, coeffs)
        for fn in (_horner_vectors, _horner_vectors.py_func):
            out = np.zeros_like(x)
            fn(x, coeffs, out)
            np.testing.assert_allclose(out, ref, rtol=0, atol=1e-14)

    def test_operators_with_vectors_and_scalars(self):
        rng = np.random.default_rng(4)
        a, b = rng.normal(size=LANES), rng.normal(size=LANES)
        ref = np.concatenate([a + b, a - b, a * b, 2.0 * a - b * 3 + 1, 1.5 - a])
        for fn in (_mixed_operators, _mixed_operators.py_func):
            out = np.zeros(5 * LANES)
            fn(a, b, out)
            np.testing.assert_allclose(out, ref, rtol=1e-15, atol=1e-15)

    def test_offsets_into_a_2d_array_are_flat(self):
        x = np.arange(3.0 * LANES).reshape(3, LANES)
        out = np.zeros((3, LANES))
        _horner_vectors(x.reshape(-1)[LANES:], np.array([0.0, 1.0]), out.reshape(-1)[LANES:])
        np.testing.assert_array_equal(out[1:], x[1:])
        assert not out[0].any()

    def test_float32_and_strided_arrays_are_refused_when_compiled(self):
        from numba.core.errors import TypingError

        with pytest.raises(TypingError):
            _horner_vectors(np.zeros(LANES, np.float32), np.ones(2), np.zeros(LANES))
        with pytest.raises(TypingError):
            _horner_vectors(np.zeros(2 * LANES)[::2], np.ones(2), np.zeros(LANES))


class TestVloadChannels:
    @pytest.mark.parametrize("dtype", [np.float32, np.float64])
    def test_channels_split_and_reversed_like_numpy(self, dtype):
        img = np.random.default_rng(5).normal(size=(5 * LANES, 3)).astype(dtype)
        flat = img.reshape(-1)
        start = 7  # pixels 7 … 7+LANES-1
        px = img[start : start + LANES].astype(np.float64)
        ref = np.concatenate([px.T.reshape(-1), px[::-1].T.reshape(-1)])
        for fn in (_split_rgb, _split_rgb.py_func):
            out = np.zeros(6 * LANES)
            sums = fn(flat, 3 * start, out)
            np.testing.assert_array_equal(out, ref)
            np.testing.assert_allclose(sums, (px[:, 0].sum(), px[:, 2].sum()), rtol=1e-14)

    def test_one_channel_reversed(self):
        a = np.arange(2.0 * LANES, dtype=np.float32)
        out = np.zeros(LANES)
        _split_one(a, 3, out)
        np.testing.assert_array_equal(out, np.arange(3.0, 3.0 + LANES)[::-1])

    def test_channel_count_must_be_a_constant_when_compiled(self):
        from numba.core.errors import TypingError

        with pytest.raises(TypingError):
            _channels_from_a_variable(np.zeros(LANES), 1, np.zeros(LANES))


class TestAlignedEmpty:
    @pytest.mark.parametrize("n", [1, 17, 1000])
    def test_starts_on_a_cache_line(self, n):
        for _ in range(5):
            a = aligned_empty(n)
            assert a.shape == (n,) and a.dtype == np.float64
            assert a.ctypes.data % 64 == 0


class TestStreamStore:
    def test_same_values_as_ordinary_stores(self):
        values = np.random.default_rng(0).normal(size=1000)
        for dtype in (np.float64, np.float32):
            out = np.zeros(1000, dtype)
            _store_all(out, values)
            np.testing.assert_array_equal(out, values.astype(dtype))
            interpreted = np.zeros(1000, dtype)
            _store_all.py_func(interpreted, values)
            np.testing.assert_array_equal(interpreted, out)

    def test_into_a_2d_array_flat(self):
        out = np.zeros((10, 3))
        _store_all(out.reshape(30), np.arange(30.0))
        np.testing.assert_array_equal(out, np.arange(30.0).reshape(10, 3))


class TestClockTicks:
    def test_monotonic_and_advancing_in_a_kernel(self):
        t, _ = _ticks(200, 2000)
        assert np.all(np.diff(t) >= 0) and t[-1] > t[0]

    def test_interpreted(self):
        a = clock_ticks()
        assert clock_ticks() >= a


class TestPrefetch:
    def test_any_index_is_harmless(self):
        a = np.arange(100.0)
        assert _prefetch_anywhere(a) == a.sum()
        assert _prefetch_anywhere.py_func(a) == a.sum()
