"""The kernel intrinsics of ``shbake/jit.py``, compiled and interpreted."""

import numpy as np

from shbake.jit import clock_ticks, jit, prefetch, stream_fence, stream_store, wide_vectors


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
