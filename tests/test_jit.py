"""The kernel intrinsics of ``shbake/jit.py``, compiled and interpreted."""

import numpy as np
import pytest

from shbake.jit import (
    LANES,
    clock_ticks,
    jit,
    prefetch,
    stream_fence,
    stream_store,
    vload,
    vsplat,
    vstore,
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
