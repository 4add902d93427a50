"""SHRM bakes (:mod:`shbake.bakers.shrm`, Ramamoorthi & Hanrahan 2002) against brute force.

Oracles: the SH rotation of :mod:`shbake.sh.rotation` applied literally (the fast kernel and
the ``R_y`` columns), brute-force texel sums over the map (prefiltered Phong maps, any BRDF
through :func:`shbake.reference.brdf_shading.brute_force_shading`), a direct texel sum of the
tangent-parameterised Kajiya–Kay lobe. Coefficients and orders:
``tests/brdf/test_reflection.py``; the cube: ``tests/texture/test_cube.py``; the command:
``tests/cli/test_shrm.py``.
"""

import numpy as np
import pytest

from shbake.bakers.shrm import bake_shrm, shrm_from_directions
from shbake.brdf import make_brdf
from shbake.brdf.reflection import brdf_coefficients, make_reflection_brdf
from shbake.brdf.sampling import tangent_frame
from shbake.conventions import n_coeffs
from shbake.preview.sphere import sphere_geometry
from shbake.reference.brdf_shading import brute_force_shading
from shbake.sh.basis import real_sh
from shbake.sh.rotation import SHRotation
from shbake.shading.shrm import evaluate_shrm, reflection_cube, shade
from shbake.texture.cube import cube_directions
from tests.helpers import write_merl
from tests.shrm_cases import rel_rms, small_env


def sphere_case(size=32):
    n, _, mask = sphere_geometry(size)
    n = n[mask]
    view = np.array([0.0, 0.0, 1.0])
    frames = np.array([np.array([*tangent_frame(*x), x]) for x in n])
    return n, view, frames, np.einsum("pij,j->pi", frames, view)


class TestShrmFromDirections:
    def test_kernel_equals_rotation_formula(self):
        rng = np.random.default_rng(2)
        F, P = 7, 3
        co = brdf_coefficients(make_reflection_brdf("ggx", {"alpha": 0.4}), F, P)
        L = rng.normal(size=(n_coeffs(F), 3))
        d = rng.normal(size=(6, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        got_g = shrm_from_directions(d, L, co)
        got_l = shrm_from_directions(d, L, co, local=True)
        for t in range(len(d)):
            a, b = np.arccos(d[t, 2]), np.arctan2(d[t, 1], d[t, 0])
            ry = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
            rz = np.array([[np.cos(b), -np.sin(b), 0], [np.sin(b), np.cos(b), 0], [0, 0, 1]])
            M = SHRotation(rz @ ry, F)
            loc = np.zeros((n_coeffs(P), 3))
            for p in range(P + 1):
                for q in range(-p, p + 1):
                    for l in range(abs(q), F + 1):
                        col = M.block(l)[:, q + l]
                        lb = L[l * l : (l + 1) ** 2]
                        loc[p * (p + 1) + q] += co.rho[l, p, abs(q)] * (lb.T @ col)
            glo = np.concatenate(
                [M.block(p) @ loc[p * p : (p + 1) ** 2] for p in range(P + 1)], axis=0
            )
            np.testing.assert_allclose(got_l[t], loc, atol=1e-12)
            np.testing.assert_allclose(got_g[t], glo, atol=1e-12)


class TestPhongAgainstBruteForce:
    """Acceptance: a P = 0 SHRM equals the brute-force prefiltered map to 1e-3."""

    @pytest.mark.parametrize("s", [8, 32, 128])
    def test_prefiltered_map(self, s):
        env = small_env("city", 256)
        dirs, om, rad = env.samples()
        bake = bake_shrm(env, make_reflection_brdf("phong-lobe", {"s": s}), eps=1e-6, face_size=8)
        assert bake.P == 0
        R = cube_directions(8)
        R = R.reshape(-1, 3)
        ref = np.zeros((len(R), 3))
        for i in range(0, len(R), 64):
            c = np.clip(R[i : i + 64] @ dirs.T, 0.0, None)
            ref[i : i + 64] = ((s + 1) / (2 * np.pi) * c**s * om) @ rad
        got = bake.cube.reshape(-1, 3).astype(float) * real_sh(np.array([0.0, 0, 1]), 0)[0]
        err = np.abs(got - ref).max() / np.abs(ref).max()
        assert err < 1e-3


class TestMicrofacetAgainstBruteForce:
    """Acceptance: σ = 0.2, error < 3 % at P = 2, falling with P (sphere, cube lookup)."""

    def test_error_falls_with_P(self):
        env = small_env("city", 128)
        dirs, om, rad = env.samples()
        n, view, frames, vl = sphere_case(32)
        rb = make_reflection_brdf("microfacet", {"sigma": 0.2})
        ref = brute_force_shading(dirs, om, rad, frames, vl, make_brdf("microfacet", sigma=0.2))
        co = brdf_coefficients(rb, 12, 4)
        errs = []
        for P in range(5):
            bake = bake_shrm(env, rb, F=12, P=P, face_size=64, coeffs_full=co)
            errs.append(rel_rms(shade(reflection_cube(bake.cube, view), n, view), ref))
        assert errs[2] < 0.03
        assert all(b < a for a, b in zip(errs, errs[1:], strict=False))


class TestGeneralBRDFs:
    @pytest.mark.parametrize(
        "name,params,P,tol",
        [
            # measured: 0.018, 0.060, 0.0038, 0.0040, 0.0070, 0.026
            ("ggx", {"alpha": 0.3}, 6, 0.03),
            ("ggx", {"alpha": 0.3, "F0": 0.04}, 6, 0.09),
            ("phong", {"n": 20}, 4, 0.008),
            ("blinn-phong", {"n": 40}, 4, 0.008),
            ("ward", {"alpha": 0.3}, 6, 0.012),
            ("lafortune", {}, 6, 0.04),
        ],
    )
    def test_sphere_against_brute_force(self, name, params, P, tol):
        env = small_env("forest", 64)
        dirs, om, rad = env.samples()
        n, view, frames, vl = sphere_case(24)
        ref = brute_force_shading(dirs, om, rad, frames, vl, make_brdf(name, **params))
        rb = make_reflection_brdf(name, params)
        bake = bake_shrm(env, rb, F=24, P=P, face_size=64)
        img = evaluate_shrm(bake.cube, np.broadcast_to(view, n.shape), n)
        assert rel_rms(img, ref) < tol


class TestMeasuredAndTangent:
    def test_merl_through_the_same_path(self, tmp_path):

        from shbake.brdf.merl import half_diff_grid

        ggx = make_brdf("ggx", F0="0.9,0.5,0.2", alpha=0.4)
        s, v = half_diff_grid()
        vals = ggx.evaluate(s, v)
        vals[(s[..., 2] <= 0) | (v[..., 2] <= 0)] = -1.0
        path = tmp_path / "ggx04.binary"
        write_merl(path, np.moveaxis(vals, -1, 0).clip(0))
        env = small_env("forest", 64)
        dirs, om, rad = env.samples()
        n, view, frames, vl = sphere_case(24)
        rb = make_reflection_brdf("merl", {}, str(path))
        ref = brute_force_shading(dirs, om, rad, frames, vl, make_brdf("merl", str(path)))
        bake = bake_shrm(env, rb, F=20, P=5, face_size=32)
        img = evaluate_shrm(bake.cube, np.broadcast_to(view, n.shape), n)
        assert rel_rms(img, ref) < 0.03

    def test_kajiya_kay_tangent_q0(self):
        env = small_env("city", 64)
        dirs, om, rad = env.samples()
        nrm, tan, mask = sphere_geometry(24)
        t = tan[mask]
        view = np.array([0.0, 0.0, 1.0])
        kd, ks, p = 0.3, 0.7, 32.0
        rb = make_reflection_brdf("kajiya-kay", {"kd": kd, "ks": ks, "p": p})
        bake = bake_shrm(env, rb, eps=0.01, face_size=32)
        assert bake.cube.shape[3] == bake.P + 1  # q = 0: P + 1 terms
        img = evaluate_shrm(bake.cube, np.broadcast_to(view, t.shape), None, "tangent", t)
        co, ci = t @ view, t @ dirs.T  # direct texel sum of the tangent-parameterised lobe
        so, si = np.sqrt(1 - co**2), np.sqrt(np.clip(1 - ci**2, 0, None))
        f = (
            kd * si / np.pi
            + ks
            * (p + 2)
            / (2 * np.pi)
            * np.clip(si * so[:, None] - ci * co[:, None], 0, None) ** p
        )
        ref = (f * om) @ rad
        assert rel_rms(img, ref) < 0.03


class TestRyColumns:
    def test_against_shrotation_to_l64(self):
        from shbake.bakers.shrm import ry_columns

        for alpha in (0.3, 1.9):
            ry = np.array([[np.cos(alpha), 0, np.sin(alpha)], [0, 1, 0],
                           [-np.sin(alpha), 0, np.cos(alpha)]])  # fmt: skip
            M = SHRotation(ry, 64)
            Y = ry_columns([np.cos(alpha)], [np.sin(alpha)], 64, 3)[0]
            for l in (0, 1, 5, 30, 64):
                for q in range(-min(l, 3), min(l, 3) + 1):
                    col = M.block(l)[:, q + l]
                    np.testing.assert_allclose(Y[q + 3, l * l : (l + 1) ** 2], col, atol=1e-9)
