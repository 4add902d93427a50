"""The BRDF models (:func:`shbake.brdf.model.make_brdf`) against plain-numpy transcriptions of
their papers' formulas, GGX's ``∫ D cosθ = 1``, a dense Gauss–Legendre albedo quadrature and
reciprocity; unknown and out-of-range parameters refused (SPEC §5).
"""

import numpy as np
import pytest

from shbake.brdf import make_brdf
from shbake.errors import ParameterError
from tests.helpers import hemi
from tests.references import albedo_quadrature


class TestModelFormulas:
    """Each kernel against a direct numpy transcription of its paper's formula."""

    def setup_method(self):
        self.s, self.v = hemi(200), hemi(200)
        h = self.s + self.v
        self.h = h / np.linalg.norm(h, axis=1, keepdims=True)

    def test_ashikhmin_shirley_eq4_eq5(self):
        nu, nv, rs, rd = 24.0, 8.0, 0.6, 0.3
        b = make_brdf("ashikhmin-shirley", nu=nu, nv=nv, Rs=rs, Rd=rd)
        s, v, h = self.s, self.v, self.h
        kh = np.sum(s * h, 1)
        e = (nu * h[:, 0] ** 2 + nv * h[:, 1] ** 2) / (1 - h[:, 2] ** 2)
        F = rs + (1 - rs) * (1 - kh) ** 5
        spec = (
            np.sqrt((nu + 1) * (nv + 1))
            / (8 * np.pi)
            * h[:, 2] ** e
            / (kh * np.maximum(s[:, 2], v[:, 2]))
            * F
        )
        diff = (
            28
            * rd
            / (23 * np.pi)
            * (1 - rs)
            * (1 - (1 - s[:, 2] / 2) ** 5)
            * (1 - (1 - v[:, 2] / 2) ** 5)
        )
        np.testing.assert_allclose(b.evaluate(s, v)[:, 0], spec + diff, rtol=1e-12)

    def test_ggx_walter_eq33_smith(self):
        a = 0.35
        b = make_brdf("ggx", F0=1.0, alpha=a)
        s, v, h = self.s, self.v, self.h
        cos2 = h[:, 2] ** 2
        D = a * a / (np.pi * (cos2 * (a * a - 1) + 1) ** 2)

        def G1(w):
            t2 = (1 - w[:, 2] ** 2) / w[:, 2] ** 2
            return 2 / (1 + np.sqrt(1 + a * a * t2))

        f = D * G1(s) * G1(v) / (4 * s[:, 2] * v[:, 2])
        np.testing.assert_allclose(b.evaluate(s, v)[:, 0], f, rtol=1e-10)

    def test_ggx_distribution_normalised(self):
        # ∫ D(h) cosθ_h dω_h = 1, anisotropic, by a dense polar grid
        from shbake.brdf.ggx import ggx_d

        x, w = np.polynomial.legendre.leggauss(2000)
        th = 0.25 * np.pi * (x + 1)
        wt = 0.25 * np.pi * w * np.sin(th) * np.cos(th)
        phi = 2 * np.pi * (np.arange(512) + 0.5) / 512
        tot = 0.0
        for t, ww in zip(th, wt, strict=True):
            tot += (
                ww
                * 2
                * np.pi
                / 512
                * sum(
                    ggx_d(0.2, 0.5, np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))
                    for p in phi[::1]
                )
            )
        assert tot == pytest.approx(1.0, abs=2e-4)

    def test_phong_normal_incidence_albedo_is_rho_s(self):
        b = make_brdf("phong", rho_s=0.8, n=200)
        assert albedo_quadrature(b, np.array([0, 0, 1.0]))[0] == pytest.approx(0.8, abs=1e-5)

    @pytest.mark.parametrize(
        "name", ["lambert", "phong", "blinn-phong", "ashikhmin-shirley", "ward", "ggx"]
    )
    def test_reciprocity(self, name):
        b = make_brdf(name)
        np.testing.assert_allclose(
            b.evaluate(self.s, self.v), b.evaluate(self.v, self.s), rtol=1e-10
        )


class TestParameters:
    def test_unknown_model_lists_allowed(self):
        with pytest.raises(ParameterError, match="allowed: lambert, phong"):
            make_brdf("cook")

    def test_unknown_parameter_lists_allowed(self):
        with pytest.raises(ParameterError, match=r"allowed: nu, nv, Rs, Rd"):
            make_brdf("ashikhmin-shirley", n=3)

    @pytest.mark.parametrize(
        "name,kw",
        [
            ("ggx", {"alpha": 0}),
            ("phong", {"n": -1}),
            ("lambert", {"rho": 1.5}),
            ("ward", {"alpha_x": "nan"}),
            ("ggx", {"F0": "1,2"}),
        ],
    )
    def test_out_of_range_refused(self, name, kw):
        with pytest.raises(ParameterError):
            make_brdf(name, **kw)

    def test_energy_breaking_refused(self):
        with pytest.raises(ParameterError, match="energy"):
            make_brdf("phong", rho_d=0.6, rho_s=0.6)
