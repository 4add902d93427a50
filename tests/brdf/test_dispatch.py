"""The numba dispatch of the analytic models (:mod:`shbake.brdf.dispatch`): the fused value and
density, and the per-line sampler, bit-identical to the separate calls.
"""

import numpy as np
import pytest

from shbake.brdf import make_brdf
from shbake.brdf.model import MODELS
from tests.helpers import hemi


class TestBrdfEvalPdf:
    """``brdf_eval_pdf`` (value and lobe density sharing one power term) returns exactly
    what ``brdf_eval`` and ``lobe_pdf`` give apart, for every analytic model."""

    @pytest.mark.parametrize("name", [m for m in MODELS if m != "merl"])
    def test_bit_identical_to_the_two_calls(self, name):
        from shbake.brdf.dispatch import brdf_eval, brdf_eval_pdf, lobe_pdf

        b = make_brdf(name)
        model, prm, data = b.spec.model_id, b.packed, b.data
        fused, apart = np.empty(3), np.empty(3)
        rng = np.random.default_rng(4)
        for s, v in zip(hemi(200, rng), hemi(200, rng), strict=True):
            p = brdf_eval_pdf(model, prm, data, *s, *v, fused)
            brdf_eval(model, prm, data, *s, *v, apart)
            assert p == lobe_pdf(model, prm, *s, *v)
            assert np.array_equal(fused, apart)


class TestLobeSampleOnLine:
    """``lobe_sample_on_line`` after ``lobe_line`` (a sample's per-line part computed once)
    gives exactly ``lobe_sample``, for every analytic model."""

    @pytest.mark.parametrize("name", [m for m in MODELS if m != "merl"])
    def test_bit_identical_to_lobe_sample(self, name):
        from shbake.brdf.dispatch import lobe_line, lobe_sample, lobe_sample_on_line

        b = make_brdf(name)
        model, prm = b.spec.model_id, b.packed
        rng = np.random.default_rng(5)
        for v, (ur, ua) in zip(hemi(100, rng), rng.random((100, 2)), strict=True):
            la, lb = lobe_line(model, prm, ua)
            assert lobe_sample_on_line(model, prm, *v, ur, la, lb) == lobe_sample(
                model, prm, *v, ur, ua
            )
