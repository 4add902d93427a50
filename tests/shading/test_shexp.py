"""SH-exp shading (:mod:`shbake.shading.shexp`): the hat weights over α, and the numba
evaluator against eq. 5, 9–12 of Silvennoinen et al. written out with numpy.
"""

import numpy as np
import pytest

from shbake.bakers.dfg import dfg_table
from shbake.errors import ParameterError
from shbake.shading.dfg import dfg_lookup
from shbake.shading.shexp import evaluate_shexp, hat_weight, hat_weights


class TestHatWeight:
    def test_partition_of_unity_and_linear_in_alpha(self):
        knots = np.array([0.2, 0.6, 1.0])
        a = np.linspace(0.1, 1.1, 41)
        w = hat_weights(knots, a)
        np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-15)
        np.testing.assert_allclose(w @ knots, np.clip(a, 0.2, 1.0), atol=1e-14)  # reproduces α
        numba_w = [[hat_weight(knots, x, k) for k in range(3)] for x in a]
        np.testing.assert_allclose(numba_w, w, atol=1e-15)
        assert np.all(hat_weights([0.3], a) == 1.0)


def shexp_in_numpy(p, q, table, v, n, alpha, f0, knots):
    """eq. 5, 9-12 written with numpy (real_sh, vmf_factors, hat_weights, dfg_lookup); the
    tail ``E1 = P(ρ) Q(ρ) A1(n·v)/A0(1)`` (docs/CONVENTIONS.md)."""
    from shbake.sh.basis import real_sh
    from shbake.shading.shexp import mirror_and_half, vmf_factors

    lp = int(round(np.sqrt(p.shape[1]))) - 1
    lq = int(round(np.sqrt(q.shape[1] + 1))) - 1
    alpha = np.broadcast_to(alpha, (len(v),))
    rho, h = mirror_and_half(v, n)
    hw = hat_weights(knots, alpha)
    pa = np.einsum("tk,kic->tic", hw, p)
    qa = np.einsum("tk,kic->tic", hw, q)
    gp = vmf_factors(lp, alpha)[:, :, None]
    gq = vmf_factors(lq, alpha)[:, 1:, None]
    log_p = np.einsum("ti,tic->tc", real_sh(rho, lp), gp[:, :, 0, None] * pa)

    def log_q(d):
        return np.einsum("ti,tic->tc", real_sh(d, lq)[:, 1:], gq[:, :, 0, None] * qa)

    e0 = np.exp(log_p + log_q(h))
    a1 = dfg_lookup(table, np.sum(n * v, axis=1), alpha)[:, 1]
    a0_normal = dfg_lookup(table, np.ones(len(v)), alpha)[:, 0]
    e1 = np.exp(log_p + log_q(rho)) * (a1 / a0_normal)[:, None]
    return f0 * e0 + (1 - f0) * e1


@pytest.fixture(scope="module")
def shexp_points():
    """Two SH-exp sets, random views and normals with n·v ≥ 0, F0 per channel, the knots."""
    rng = np.random.default_rng(11)
    lp, lq, T = 4, 2, 700
    p = rng.normal(size=(2, (lp + 1) ** 2, 3)) * 0.3
    q = rng.normal(size=(2, (lq + 1) ** 2 - 1, 3)) * 0.3
    n = rng.normal(size=(T, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    v = rng.normal(size=(T, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    v *= np.sign(np.sum(v * n, axis=1))[:, None]  # n·v ≥ 0
    table = dfg_table(size=8, samples=256)
    return p, q, table, v, n, np.array([1.0, 0.5, 0.04]), np.array([0.2, 0.9])


class TestEvaluateShexp:
    def test_matches_the_formula_in_numpy(self, shexp_points):
        # per-point α in runs of equal values that change (the kernel reuses the per-α
        # factors within a run)
        rng = np.random.default_rng(12)
        alpha = np.repeat(rng.uniform(0.1, 1.0, 70), 10)
        alpha[::7] = rng.uniform(0.1, 1.0, alpha[::7].size)
        p, q, table, v, n, f0, knots = shexp_points
        got = evaluate_shexp(p, q, table, v, n, alpha, f0, knots)
        want = shexp_in_numpy(p, q, table, v, n, alpha, f0, knots)
        np.testing.assert_allclose(got, want, rtol=1e-12)

    @pytest.mark.parametrize("alpha", [0.05, 0.2, 0.47, 0.9, 1.0])
    def test_one_alpha_fused_path_matches_the_formula_in_numpy(self, shexp_points, alpha):
        # a scalar α takes the block-fused path (add_sums); α = 0.05 lies below the knots
        p, q, table, v, n, f0, knots = shexp_points
        got = evaluate_shexp(p, q, table, v, n, alpha, f0, knots)
        want = shexp_in_numpy(p, q, table, v, n, alpha, f0, knots)
        np.testing.assert_allclose(got, want, rtol=1e-12)

    def test_one_alpha_refuses_v_opposite_n(self, shexp_points):
        p, q, table = shexp_points[:3]
        with pytest.raises(ParameterError, match="v = -n"):
            evaluate_shexp(p, q, table, [[0, 0, 1.0], [0, 0, -1.0]], [[0, 0, 1.0]] * 2, 0.5,
                           knots=shexp_points[6])  # fmt: skip
