"""Real SH basis (SPEC §2): closed forms, orthonormality to lmax 64, extremes."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shbake.conventions import check_vectors, unit_vectors
from shbake.errors import ParameterError
from shbake.sh.basis import (
    BLOCK,
    add_sums,
    evaluate,
    real_sh,
    real_sh_numba,
    sum_scratch,
    sum_weights,
)
from tests.helpers import gauss_legendre_sphere


class TestCheckVectors:
    def test_returns_float64_unchanged_and_refuses_bad_vectors(self):
        v = np.array([[1, 2, 3], [-1e-300, 0, 0]])
        out = check_vectors(v)
        assert out.dtype == np.float64 and np.array_equal(out, v)
        for bad, words in (([[0.0, 0.0, 0.0]], "non-zero"), ([[np.inf, 0.0, 0.0]], "finite"),
                           ([[1.0, 0.0]], "last axis"), ([[np.nan, 1.0, 1.0]], "finite")):
            with pytest.raises(ParameterError, match=words):
                check_vectors(bad, "normals")


class TestUnitVectors:
    def test_unit_length_at_any_magnitude(self):
        # Scaled by the largest component first: tiny and huge vectors normalise exactly
        # as their unit-scale twins (numpy's direct norm would underflow or overflow).
        rng = np.random.default_rng(3)
        v = rng.normal(size=(50, 3))
        ref = v / np.sqrt(np.sum(v * v, axis=1, keepdims=True))
        for scale in (1e-300, 1e-160, 1.0, 1e160, 1e300):
            got = unit_vectors(v * scale)
            np.testing.assert_allclose(got, ref, rtol=0, atol=4e-16)
        assert unit_vectors(np.array([5e-324, 0.0, 0.0])).tolist() == [1.0, 0.0, 0.0]

    def test_shape_kept_and_bad_vectors_refused(self):
        assert unit_vectors(np.ones((2, 4, 3))).shape == (2, 4, 3)
        with pytest.raises(ParameterError, match="non-zero"):
            unit_vectors([[0.0, 0.0, 0.0]], "views")


class TestRealSh:
    def test_closed_forms_of_spec(self):
        rng = np.random.default_rng(0)
        d = rng.normal(size=(100, 3))
        d /= np.linalg.norm(d, axis=1)[:, None]
        x, y, z = d.T
        c1, c2 = np.sqrt(3 / (4 * np.pi)), np.sqrt(15 / (4 * np.pi))
        expected = np.stack(
            [
                np.full_like(x, 0.5 * np.sqrt(1 / np.pi)),
                c1 * y,
                c1 * z,
                c1 * x,
                c2 * x * y,
                c2 * y * z,
                np.sqrt(5 / (16 * np.pi)) * (3 * z * z - 1),
                c2 * x * z,
                np.sqrt(15 / (16 * np.pi)) * (x * x - y * y),
            ],
            axis=1,
        )
        np.testing.assert_allclose(real_sh(d, 2), expected, atol=1e-15)

    def test_no_condon_shortley_phase(self):
        # y_{l,l} at +X is positive for every l (a CS phase would alternate signs).
        y = real_sh([1.0, 0.0, 0.0], 20)
        assert all(y[l * (l + 1) + l] > 0 for l in range(21))

    def test_orthonormal_to_lmax_64(self):
        lmax = 64
        from scipy.linalg.blas import dsyrk

        d, w = gauss_legendre_sphere(lmax)
        Y = real_sh_numba(d, lmax)
        # the Gram matrix's upper triangle (symmetric rank-k update: half a matmul's work)
        gram = np.triu(dsyrk(1.0, np.asfortranarray(Y * np.sqrt(w)[:, None]), trans=1))
        assert np.abs(gram - np.eye(gram.shape[0])).max() < 1e-10

    def test_finite_at_lmax_128_including_poles(self):
        d = np.array([[0, 0, 1.0], [0, 0, -1.0], [1, 0, 0], [1e-9, 0, 1.0], [0.6, 0.8, 0.0]])
        Y = real_sh(d, 128)
        assert np.all(np.isfinite(Y))
        # At the poles only m = 0 survives and y_l0(±z) = ±^l sqrt((2l+1)/4π).
        l = np.arange(129)
        np.testing.assert_allclose(Y[0, l * (l + 1)], np.sqrt((2 * l + 1) / (4 * np.pi)))
        np.testing.assert_allclose(
            Y[1, l * (l + 1)], (-1.0) ** l * np.sqrt((2 * l + 1) / (4 * np.pi))
        )

    def test_addition_theorem_at_lmax_100(self):
        # Σ_m y_lm(d)² = (2l+1)/(4π) for every l and d — checks large-l accuracy.
        d = np.random.default_rng(5).normal(size=(20, 3))
        Y = real_sh_numba(d, 100)
        for l in (10, 50, 100):
            np.testing.assert_allclose(
                np.sum(Y[:, l * l : (l + 1) ** 2] ** 2, axis=1),
                (2 * l + 1) / (4 * np.pi),
                rtol=1e-11,
            )

    @settings(max_examples=50, deadline=None)
    @given(
        st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3).filter(
            lambda v: sum(c * c for c in v) > 1e-6
        )
    )
    def test_numba_matches_numpy(self, v):
        np.testing.assert_allclose(real_sh_numba(v, 12), real_sh(v, 12), atol=1e-13)

    def test_rejects_bad_input(self):
        with pytest.raises(ParameterError):
            real_sh([0.0, 0.0, 0.0], 2)
        with pytest.raises(ParameterError):
            real_sh([1.0, 0.0, 0.0], 129)
        with pytest.raises(ParameterError):
            real_sh([np.nan, 0.0, 1.0], 2)


class TestEvaluate:
    def test_reconstructs_a_known_function(self):
        # f = 2 y_0 + 3 y_2 (= 3 c1 z + const) evaluated analytically.
        c = np.zeros(9)
        c[0], c[2] = 2.0, 3.0
        d = np.array([[0, 0, 1.0], [0, 1.0, 0]])
        expected = 2 * 0.5 / np.sqrt(np.pi) + 3 * np.sqrt(3 / (4 * np.pi)) * d[:, 2]
        np.testing.assert_allclose(evaluate(c, d), expected)


class TestAddSums:
    @pytest.mark.parametrize("lmax", [0, 2, 8])
    @pytest.mark.parametrize("nc", [1, 2, 3])
    @pytest.mark.parametrize("nb", [1, 13, BLOCK])
    def test_adds_the_numpy_sum(self, lmax, nc, nb):
        # one block of a kernel's points, directions of any length, added into acc
        rng = np.random.default_rng(lmax * 100 + nc * 10 + nb)
        d = rng.normal(size=(BLOCK, 3)) * rng.uniform(0.1, 10.0, size=(BLOCK, 1))
        c = rng.normal(size=((lmax + 1) ** 2, nc))
        acc = rng.normal(size=(BLOCK, nc))
        want = acc.copy()
        want[:nb] += real_sh(d[:nb], lmax) @ c
        bad = add_sums(d, nb, sum_weights(c), lmax, sum_scratch(), acc)
        assert bad == 0
        np.testing.assert_allclose(acc, want, rtol=1e-13, atol=1e-13 * np.abs(want).max())

    def test_counts_zero_directions(self):
        d = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [np.nan, 0.0, 1.0]])
        acc = np.zeros((3, 1))
        assert add_sums(d, 3, sum_weights(np.ones((4, 1))), 1, sum_scratch(), acc) == 2

    def test_weights_refuse_more_than_three_channels(self):
        with pytest.raises(ParameterError):
            sum_weights(np.ones((9, 4)))
