"""The lower bound on a few lights + 9 SH coefficients (:mod:`tests.light_bound`), checked
against fits of lights at known directions by an independent linear programme: never above
any fit whose lights lie in its cells, equal to it as the cells shrink, and a branch and
bound that proves what cannot be met and never what can (issue 33's proof for studio,
``bench/irradiance_bound.py``, rests on these)."""

import numpy as np
import pytest
from scipy.optimize import linprog

from shbake.sh.basis import real_sh
from shbake.sh.point_sets import fibonacci_sphere
from tests.light_bound import TAU_MAX, Relaxation, _faces, branch_and_bound

NORMALS = fibonacci_sphere(512)
CAP = 0.10
LIMITS = (0.01, CAP)


def lights_term(dirs, form_factors):
    """Each light's diffuse term ``max(0, n·d + f)`` at :data:`NORMALS` (N × K)."""
    return np.maximum(0.0, NORMALS @ np.asarray(dirs).T + np.asarray(form_factors))


def least_mean(target, dirs, form_factors, cap=CAP):
    """The least mean relative error of 9 coefficients + lights at ``dirs`` (intensities
    ≥ 0), every error ≤ ``cap`` (``inf``: none can): the programme written directly."""
    A = np.hstack([real_sh(NORMALS, 2), lights_term(dirs, form_factors)]) / target[:, None]
    n, k = A.shape
    eye = np.eye(n)
    res = linprog(np.concatenate([np.zeros(k), np.full(n, 1.0 / n)]),
                  A_ub=np.block([[A, -eye], [-A, -eye]]),
                  b_ub=np.concatenate([np.ones(n), -np.ones(n)]),
                  bounds=[(None, None)] * 9 + [(0, None)] * (k - 9) + [(0, cap)] * n,
                  method="highs")  # fmt: skip
    return np.inf if res.status == 2 else res.fun


def cell_of(d, f, level, tau_level, faces):
    """The cell of ``faces`` at ``level`` (and ``τ`` interval at ``tau_level``; ``-1``:
    directional) holding direction ``d`` with form factor ``f``."""
    face = next(k for k, (a, eu, ev) in enumerate(faces)
                if d @ a > 0 and max(abs(d @ eu), abs(d @ ev)) <= d @ a)  # fmt: skip
    a, eu, ev = faces[face]
    x, y = d @ eu / (d @ a), d @ ev / (d @ a)
    h = 2.0 / (1 << level)
    i, j = (min(int((c + 1.0) / h), (1 << level) - 1) for c in (x, y))
    if tau_level < 0:
        return face, level, i, j, -1, 0
    tau = f * np.sqrt(1.0 + x * x + y * y)
    return face, level, i, j, tau_level, int(tau / (TAU_MAX / (1 << tau_level)))


def studio_like(seed):
    """A positive irradiance with two compact sources, one soft: a target no L2 fits."""
    d = np.array([[0.74, 0.66, -0.10], [-0.89, 0.05, 0.45]])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rng = np.random.default_rng(seed)
    return 0.4 + 0.1 * NORMALS[:, 2] + lights_term(d, [0.0, 0.15]) @ rng.uniform(1, 3, 2)


def cells_at(dirs, form_factors, level, tau_level, faces):
    return [cell_of(d, f, level, tau_level, faces) for d, f in zip(dirs, form_factors, strict=True)]


def random_lights(rng, count, rect):
    d = rng.normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d, rng.uniform(0.0, 0.4, count) if rect else np.zeros(count)


def random_fits(seed, variant, lights, rect, trials):
    """``trials`` fits of ``lights`` random lights to a studio-like target (``variant``), each
    ``(faces, bound, dirs, form factors, the fit's least mean error)``."""
    rng = np.random.default_rng(seed)
    faces = _faces(6)
    target = studio_like(variant)
    bound = Relaxation(NORMALS, target, len(target), faces)
    for _ in range(trials):
        dirs, ffs = random_lights(rng, lights, rect)
        yield faces, bound, dirs, ffs, least_mean(target, dirs, ffs, cap=10.0)


class TestRelaxation:
    @pytest.mark.parametrize("rect", [False, True])
    def test_never_above_a_fit_in_its_cells(self, rect):
        for faces, bound, dirs, ffs, fit in random_fits(3, 1, 3, rect, 4):
            for level in (0, 2, 4, 7):
                cells = cells_at(dirs, ffs, level, max(level - 1, 0) if rect else -1, faces)
                assert bound.lower(cells, 10.0) <= fit + 1e-7

    @pytest.mark.parametrize("rect", [False, True])
    def test_meets_the_fit_as_cells_shrink(self, rect):
        for faces, bound, dirs, ffs, fit in random_fits(5, 2, 2, rect, 3):
            cells = cells_at(dirs, ffs, 16, 16 if rect else -1, faces)
            assert bound.lower(cells, 10.0) == pytest.approx(fit, rel=1e-3, abs=1e-6)

    def test_infeasible_only_where_no_fit_keeps_the_max(self):
        faces = _faces(6)
        target = studio_like(3)
        bound = Relaxation(NORMALS, target, len(target), faces)
        d = np.array([[0.74, 0.66, -0.10]]) / np.linalg.norm([0.74, 0.66, -0.10])
        verdicts = []
        for cap in (0.05, 0.2, 1.0):
            fit = least_mean(target, d, [0.0], cap)
            got = bound.lower([cell_of(d[0], 0.0, 14, -1, faces)], cap)
            assert got <= fit + 1e-9  # inf only where the fit is too
            verdicts.append(got == np.inf)
        assert verdicts == [True, False, False]  # the limit binds, then does not

    def test_a_directional_light_and_its_opposite_fit_alike(self):
        # the reason three cube faces cover directional lights
        target = studio_like(4)
        d = np.array([[0.3, -0.5, 0.81]])
        assert least_mean(target, d, [0.0], 10.0) == pytest.approx(
            least_mean(target, -d, [0.0], 10.0), rel=1e-6)  # fmt: skip


class TestBranchAndBound:
    def test_never_proves_what_a_light_meets(self):
        d = np.array([[0.36, -0.48, 0.8]])
        target = 0.5 + 0.2 * NORMALS[:, 0] + 2.0 * lights_term(d, [0.0])[:, 0]
        assert least_mean(target, d, [0.0]) < 1e-9
        for family in ("directional", "rect"):
            out = branch_and_bound(NORMALS, target, family, 1, LIMITS, max_level=4)
            assert not out["proved"]
            assert out["generations"][-1]["finest_level"] == 5

    def test_proves_what_no_light_meets(self):
        target = studio_like(5)
        out = branch_and_bound(NORMALS, target, "directional", 1, LIMITS)
        assert out["proved"]
        # and a search agrees: no single light of a 250-direction grid meets it
        grid = fibonacci_sphere(250)
        assert min(least_mean(target, g[None], [0.0]) for g in grid) > LIMITS[0]
