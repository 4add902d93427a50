"""Fused and stored-basis SH evaluation (issue 15) against sphericart (independent code).

sphericart (Bigi et al. 2023, test-only dependency) uses the same real,
orthonormal, no-Condon–Shortley basis and index order as SPEC §2 (checked
here at lmax 3 column by column), so its output is compared directly.
"""

import numpy as np
import pytest

from shbake.errors import ParameterError
from shbake.sh.basis import (
    evaluate,
    legendre_next,
    real_sh,
    real_sh_into,
    recurrence_tables,
    scaled_recurrence_tables,
)

sphericart = pytest.importorskip("sphericart")


def directions(n, seed=0, scale=True):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d[:6] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1e-300], [1e-3, 0, 1]]
    if scale:
        d *= rng.uniform(0.1, 10.0, size=(n, 1))  # not unit length: normalised inside
    return d


def oracle(d, lmax):
    u = d / np.abs(d).max(axis=1)[:, None]
    u /= np.linalg.norm(u, axis=1)[:, None]
    return sphericart.SphericalHarmonics(lmax).compute(u)


class TestRealShInto:
    @pytest.mark.parametrize("lmax", [0, 1, 2, 8, 30])
    def test_matches_sphericart(self, lmax):
        d = directions(2000, seed=lmax)
        np.testing.assert_allclose(real_sh_into(d, lmax), oracle(d, lmax), rtol=0, atol=1e-12)

    def test_writes_into_a_preallocated_output(self):
        d = directions(1000)
        out = np.full((1000, 81), np.nan)
        res = real_sh_into(d, 8, out)
        assert res is out
        np.testing.assert_allclose(out, oracle(d, 8), atol=1e-12)

    def test_batch_shape_and_float32(self):
        d = directions(60)
        d[4] = [0, 0, 1e-30]  # 1e-300 is 0 in float32
        d = d.reshape(3, 20, 3)
        y = real_sh_into(d.astype(np.float32), 4)
        assert y.shape == (3, 20, 25)
        ref = oracle(d.astype(np.float32).astype(np.float64).reshape(-1, 3), 4)
        np.testing.assert_allclose(y.reshape(-1, 25), ref, atol=1e-12)

    @pytest.mark.parametrize("bad", [[0.0, 0.0, 0.0], [np.nan, 0, 1], [np.inf, 0, 0]])
    def test_rejects_unusable_directions(self, bad):
        d = directions(300)
        d[123] = bad
        with pytest.raises(ParameterError, match="1 directions"):
            real_sh_into(d, 2)

    def test_rejects_a_wrong_output(self):
        with pytest.raises(ParameterError):
            real_sh_into(directions(10), 2, np.empty((10, 8)))
        with pytest.raises(ParameterError):
            real_sh_into(directions(10), 2, np.empty((10, 9), dtype=np.float32))


class TestEvaluate:
    @pytest.mark.parametrize("lmax", [0, 1, 2, 3, 8, 30])
    @pytest.mark.parametrize("channels", [1, 3, 4])
    def test_matches_sphericart_times_coefficients(self, lmax, channels):
        d = directions(1500, seed=lmax + 10 * channels)
        c = np.random.default_rng(lmax).normal(size=((lmax + 1) ** 2, channels))
        ref = oracle(d, lmax) @ c
        got = evaluate(c, d)
        assert np.abs(got - ref).max() < 1e-12 * np.abs(ref).max()

    def test_one_dimensional_coefficients_and_batch_shape(self):
        d = directions(200).reshape(10, 20, 3)
        c = np.random.default_rng(1).normal(size=16)
        got = evaluate(c, d)
        assert got.shape == (10, 20)
        np.testing.assert_allclose(got.ravel(), oracle(d.reshape(-1, 3), 3) @ c, atol=1e-12)

    def test_constant_function(self):
        # f = c_0 y_0 = c_0 / sqrt(4π) everywhere (an analytic value).
        c = np.zeros((81, 3))
        c[0] = [1.0, 2.0, 3.0]
        got = evaluate(c, directions(500))
        np.testing.assert_allclose(
            got, np.tile([1, 2, 3], (500, 1)) / np.sqrt(4 * np.pi), rtol=1e-15
        )

    def test_preallocated_output(self):
        d = directions(300)
        c = np.random.default_rng(2).normal(size=(25, 3))
        out = np.empty((300, 3))
        assert evaluate(c, d, out=out) is out
        np.testing.assert_allclose(out, real_sh(d, 4) @ c, atol=1e-12)

    def test_rejects_bad_input(self):
        with pytest.raises(ParameterError):
            evaluate(np.ones(10), directions(8))
        d = directions(8)
        d[2] = 0.0
        with pytest.raises(ParameterError):
            evaluate(np.ones(9), d)
        with pytest.raises(ParameterError):
            evaluate(np.ones(9), np.ones((5, 2)))


class TestScaledRecurrenceTables:
    """The rescaled recurrence of the fused kernel against the unscaled one, step by step."""

    @pytest.mark.parametrize("lmax", [1, 8, 128])
    def test_gamma_times_r_is_q(self, lmax):
        qmm, a, b = recurrence_tables(lmax)
        gamma, beta = scaled_recurrence_tables(lmax)
        z = np.linspace(-1.0, 1.0, 41)
        step = legendre_next.py_func
        for m in range(lmax + 1):
            q1, q2 = np.full_like(z, qmm[m]), np.zeros_like(z)
            r1, r2 = q1.copy(), q2.copy()
            for l in range(m + 1, lmax + 1):
                q1, q2 = step(a[l, m], b[l, m], z, q1, q2), q1
                r1, r2 = z * r1 - beta[l, m] * r2, r1
                scale = np.abs(q1).max()
                np.testing.assert_allclose(gamma[l, m] * r1, q1, rtol=0, atol=1e-13 * scale)

    def test_finite_and_read_only(self):
        gamma, beta = scaled_recurrence_tables(128)
        assert np.isfinite(gamma).all() and gamma.max() < 4.0**128
        assert not gamma.flags.writeable and not beta.flags.writeable


class TestEvaluateKernel:
    """The fused numba kernel itself (``method="numba"``), whatever the job size."""

    @pytest.mark.parametrize("lmax", [0, 1, 2, 3, 4, 5, 8, 13, 30])
    @pytest.mark.parametrize("channels", [1, 3, 4, 7])
    def test_matches_sphericart_times_coefficients(self, lmax, channels):
        # 700 directions: two full blocks and a partial one; every column length
        # (1 … lmax+1, so every chunk variant of the kernel) occurs.
        d = directions(700, seed=lmax + 100 * channels)
        c = np.random.default_rng(lmax + 1).normal(size=((lmax + 1) ** 2, channels))
        ref = oracle(d, lmax) @ c
        got = evaluate(c, d, method="numba")
        assert np.abs(got - ref).max() < 1e-12 * np.abs(ref).max()

    def test_tiny_huge_and_float32_directions(self):
        d = directions(600)
        d[10] = [1e-200, -3e-201, 2e-200]
        d[11] = [1e200, 1e199, -5e200]
        d[12] = [0.0, 0.0, -1e-310]  # subnormal
        c = np.random.default_rng(3).normal(size=(81, 3))
        ref = oracle(d, 8) @ c
        got = evaluate(c, d, method="numba")
        assert np.abs(got - ref).max() < 1e-12 * np.abs(ref).max()
        d32 = d[20:].astype(np.float32)
        ref32 = oracle(d32.astype(np.float64), 8) @ c
        got32 = evaluate(c, d32, method="numba")
        assert np.abs(got32 - ref32).max() < 1e-12 * np.abs(ref32).max()

    @pytest.mark.parametrize("lmax", [2, 8, 30, 64, 128])
    def test_agrees_with_the_numpy_path(self, lmax):
        # numpy path: stored basis (real_sh) then a matrix product, another summation order.
        d = directions(900, seed=lmax)
        c = np.random.default_rng(lmax).normal(size=((lmax + 1) ** 2, 3))
        ref = evaluate(c, d, method="numpy")
        got = evaluate(c, d, method="numba")
        assert np.abs(got - ref).max() < 1e-12 * np.abs(ref).max()

    def test_same_bytes_for_any_thread_count(self, monkeypatch):
        d = directions(300_000, seed=5)
        c = np.random.default_rng(5).normal(size=(81, 3))
        res = []
        for threads in ("1", "2", "3"):
            monkeypatch.setenv("SHBAKE_THREADS", threads)
            res.append(evaluate(c, d, method="numba"))
        assert res[0].tobytes() == res[1].tobytes() == res[2].tobytes()

    @pytest.mark.parametrize("bad", [[0.0, 0.0, 0.0], [np.nan, 0, 1], [0, -np.inf, 0]])
    def test_counts_unusable_directions(self, bad):
        d = directions(600)
        d[[5, 400]] = bad
        with pytest.raises(ParameterError, match="2 directions"):
            evaluate(np.ones(16), d, method="numba")
