"""The SH-exp fit (:mod:`shbake.bakers.shexp`, Silvennoinen et al. 2025): the factored design
against the explicit eq. 14 rows and a dense least-squares solve, exact recovery of targets of
the model's form (checked by the independent numba evaluator), the shaded weights, extremes.

The other parts of ``probe-fit``: GGX ground truth ``tests/reference/test_ggx.py``, targets
``tests/bakers/test_shexp_targets.py`` and ``test_shexp_sh_targets.py``, DFG table
``tests/bakers/test_dfg.py``, shading ``tests/shading/test_shexp.py``, split-sum
``tests/bakers/test_splitsum.py``, jobs ``tests/batch/test_probe_jobs.py``, the command
``tests/cli/test_probe_fit.py``.
"""

from dataclasses import replace

import numpy as np
import pytest

from shbake.bakers.dfg import dfg_table
from shbake.bakers.shexp import FitConfig, FitPlan, design_rows
from shbake.reference.ggx import ggx_integrals
from shbake.shading.shexp import evaluate_shexp
from tests.helpers import smooth_map
from tests.probe_cases import SMALL


class TestDesign:
    def test_structured_products_equal_explicit_rows(self):
        """The factored normal matrices and right-hand sides equal those of the explicit
        eq. 14 rows (K = 3 hat sets), and the solve equals a dense least-squares solve."""
        cfg = FitConfig(normals=8, views=8, alpha_count=5, sets=3, samples=64)
        plan = FitPlan(cfg, (32, 64))
        A = design_rows(plan.views, plan.normals, plan.alpha, cfg.lmax_p, cfg.lmax_q, plan.knots)
        rng = np.random.default_rng(1)
        w, b = rng.random((A.shape[0], 2)), rng.random((A.shape[0], 2))
        x = rng.normal(size=A.shape[1])
        d = plan.design
        np.testing.assert_allclose(d.apply(x), A @ x, atol=1e-13)
        np.testing.assert_allclose(d.normal_matrices(w)[1], A.T @ (A * w[:, 1:2]), atol=1e-12)
        np.testing.assert_allclose(d.rhs(w * b), A.T @ (w * b), atol=1e-12)
        ref = np.linalg.lstsq(A * np.sqrt(w[:, 1:2]), b[:, 1] * np.sqrt(w[:, 1]), rcond=None)[0]
        np.testing.assert_allclose(d.solve(w, b)[:, 1], ref, atol=1e-6)


class TestShexpFit:
    @pytest.mark.parametrize("sets", [1, 2, 3])
    def test_recovers_exact_sh_exponential(self, sets):
        cfg = FitConfig(normals=16, views=16, samples=64, sets=sets, weights="log", polish=0)
        plan = FitPlan(cfg, (32, 64))
        rng = np.random.default_rng(2)
        x = rng.normal(scale=0.3, size=(sets * cfg.n_params, 3))
        A = design_rows(plan.views, plan.normals, plan.alpha, cfg.lmax_p, cfg.lmax_q, plan.knots)
        e0 = np.exp(A @ x)  # targets exactly of the model's form
        probe = plan.fit_targets(e0)
        got = np.concatenate([probe.p, probe.q], axis=1).reshape(-1, 3)
        np.testing.assert_allclose(got, x, atol=1e-7)
        # the numba evaluator (independent of the numpy design rows) reproduces the targets
        table = dfg_table(size=8, samples=256)
        est = evaluate_shexp(probe.p, probe.q, table, plan.views, plan.normals, plan.alpha,
                             knots=probe.knots)  # fmt: skip
        np.testing.assert_allclose(est, e0, rtol=1e-6)

    def test_shaded_weights_lower_the_shaded_error(self):
        """``shaded-nv`` (and its Gauss–Newton polish) minimise what the evaluation measures:
        the on-screen (2 n·v weighted) squared error against an independent re-integration
        of the targets is below the log fit's."""
        img = smooth_map(32, sun=(50.0, 40.0, 30.0))
        table = dfg_table(size=8, samples=256)
        errors = {}
        for name, kw in {"log": dict(weights="log", polish=0),
                         "shaded-nv": dict(weights="shaded-nv", polish=0),
                         "polish": dict(weights="shaded-nv", polish=2)}.items():  # fmt: skip
            plan = FitPlan(FitConfig(normals=16, views=16, samples=256, **kw), (32, 64))
            probe = plan.fit(img)
            truth, _ = ggx_integrals(img, plan.views, plan.normals, plan.alpha, 4096)
            est = evaluate_shexp(probe.p, probe.q, table, plan.views, plan.normals, plan.alpha,
                                 knots=probe.knots)  # fmt: skip
            errors[name] = np.sum(plan.view_weight[:, None] * (est - truth) ** 2)
        assert errors["shaded-nv"] < 0.8 * errors["log"], errors
        assert errors["polish"] <= 1.01 * errors["shaded-nv"], errors

    def test_alpha_weight_moves_accuracy_to_the_narrow_end(self):
        """``alpha_weight`` trades the two ends of the range: against an independent
        re-integration of the targets, the on-screen error at the smallest fit ``α`` falls
        and the one at the largest rises as the exponent goes 0 → 2; 0 is the unweighted
        fit (every sample's weight as before, bit for bit)."""
        img = smooth_map(32, sun=(50.0, 40.0, 30.0))
        table = dfg_table(size=8, samples=256)
        ends = {}
        for s in (0.0, 2.0):
            cfg = FitConfig(normals=16, views=16, samples=256, alpha_weight=s)
            plan = FitPlan(cfg, (32, 64))
            probe = plan.fit(img)
            truth, _ = ggx_integrals(img, plan.views, plan.normals, plan.alpha, 4096)
            est = evaluate_shexp(probe.p, probe.q, table, plan.views, plan.normals, plan.alpha,
                                 knots=probe.knots)  # fmt: skip
            err = plan.view_weight[:, None] * (est - truth) ** 2
            ends[s] = [err[plan.alpha == a].sum() / (plan.view_weight[:, None] * truth**2)[
                plan.alpha == a].sum() for a in (cfg.alpha_min, cfg.alpha_max)]
            if s == 0.0:
                np.testing.assert_array_equal(plan.sample_weight, plan.view_weight)
        assert ends[2.0][0] < ends[0.0][0] and ends[2.0][1] > ends[0.0][1], ends

    def test_paper_config(self):
        cfg = FitConfig.paper()
        assert (cfg.sets, cfg.weights, cfg.polish, cfg.alpha_count) == (1, "log", 0, 4)
        assert cfg.alpha_weight == 0.0
        np.testing.assert_allclose(cfg.alphas, [0.2, 0.2 + 0.8 / 3, 0.2 + 1.6 / 3, 1.0])

    @pytest.mark.parametrize("weights", ["log", "shaded-nv"])
    def test_black_map_is_finite(self, weights):
        probe = FitPlan(replace(SMALL, weights=weights), (32, 64)).fit(
            np.zeros((32, 64, 3), np.float32)
        )
        assert np.all(np.isfinite(probe.p)) and np.all(np.isfinite(probe.q))
        table = dfg_table(size=8, samples=256)
        out = evaluate_shexp(probe.p, probe.q, table, [[0, 0, 1.0]], [[0, 0, 1.0]], 0.5,
                             knots=probe.knots)  # fmt: skip
        assert np.all(out < 1e-20)

    @pytest.mark.parametrize("weights", ["log", "shaded", "shaded-nv"])
    def test_sun_of_1e5_is_finite(self, weights):
        cfg = replace(SMALL, weights=weights, polish=2)
        probe = FitPlan(cfg, (32, 64)).fit(smooth_map(32, sun=(1e5, 1e5, 1e5)))
        assert np.all(np.isfinite(probe.p)) and np.all(np.isfinite(probe.q))

    def test_negative_zero_alpha_weight_is_zero(self):
        """``--alpha-weight -0`` is the fit of ``0``: the recorded config (the asset's bytes)
        is the same."""
        import math

        assert math.copysign(1.0, FitConfig(alpha_weight=-0.0).alpha_weight) == 1.0
        assert FitConfig(alpha_weight=-0.0).as_dict() == FitConfig(alpha_weight=0.0).as_dict()

    def test_bad_config_refused(self):
        for kw in ({"weights": "l1"}, {"alpha_min": 0.0}, {"alpha_max": 1.5}, {"lmax_p": 12},
                   {"floor": 0.0}, {"sets": 0}, {"sets": 5, "alpha_count": 8},
                   {"alpha_min": float("nan")}, {"alpha_weight": -1.0},
                   {"alpha_weight": 4.5}, {"alpha_weight": float("nan")}):  # fmt: skip
            with pytest.raises(ValueError):
                FitConfig(**kw)
