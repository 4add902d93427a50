"""``shbake/jit.py``: the kernel decorator, the numba registration hook and the one threading
model (:func:`~shbake.jit.run_blocks`), including every kernel that ran on numba's ``prange``
before issue 28: its results must not depend on how many threads shared its blocks."""

import ast
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from shbake import jit

PACKAGE = Path(jit.__file__).parent


def two_threads(monkeypatch, threads: int = 2):
    """Let :func:`run_blocks` split even the tests' small jobs over ``threads`` threads."""
    monkeypatch.setenv("SHBAKE_THREADS", str(threads))
    monkeypatch.setattr(jit, "MIN_WORK_PER_THREAD", 1)


class TestRunBlocks:
    @pytest.mark.parametrize("threads", [1, 2, 3])
    @pytest.mark.parametrize("n_blocks", [0, 1, 7, 100])
    def test_every_block_exactly_once(self, monkeypatch, threads, n_blocks):
        two_threads(monkeypatch, threads)
        seen = []
        lock = threading.Lock()

        def kernel(tag, b0, b1):
            assert tag == "args first" and 0 <= b0 <= b1 <= n_blocks
            with lock:
                seen.extend(range(b0, b1))

        jit.run_blocks(kernel, n_blocks, 1e9, "args first")
        assert sorted(seen) == list(range(n_blocks))

    def test_small_jobs_run_once_on_the_calling_thread(self, monkeypatch):
        monkeypatch.setenv("SHBAKE_THREADS", "2")
        calls = []
        jit.run_blocks(lambda b0, b1: calls.append((b0, b1, threading.get_ident())), 50, 10.0)
        assert calls == [(0, 50, threading.get_ident())]

    def test_an_error_in_any_thread_is_raised(self, monkeypatch):
        two_threads(monkeypatch)

        def kernel(b0, b1):
            if b0 <= 37 < b1:
                raise ValueError("block 37")

        with pytest.raises(ValueError, match="block 37"):
            jit.run_blocks(kernel, 64, 1e9)

    def test_thread_budget_order(self, monkeypatch):
        monkeypatch.setenv("NUMBA_NUM_THREADS", "3")
        monkeypatch.setenv("SHBAKE_THREADS", "5")
        assert jit.thread_budget() == 5
        monkeypatch.delenv("SHBAKE_THREADS")
        assert jit.thread_budget() == 3
        monkeypatch.delenv("NUMBA_NUM_THREADS")
        assert jit.thread_budget() == len(os.sched_getaffinity(0))

    def test_use_one_thread_limits_every_kernel(self, monkeypatch):
        monkeypatch.setenv("SHBAKE_THREADS", "4")
        jit.use_one_thread()
        assert jit.thread_budget() == 1 and jit.thread_count(1e12, 1000) == 1


class TestOneThreadingModel:
    def test_no_kernel_uses_numba_parallel(self):
        """``prange``/``parallel=True`` would bring back numba's static split and thread pool
        (the module docstring of ``shbake/jit.py`` says why run_blocks replaced them)."""
        bad = []
        for path in sorted(PACKAGE.rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for node in ast.walk(tree):
                name = getattr(node, "attr", None) or getattr(node, "id", None)
                if name in ("prange", "pjit"):
                    bad.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {name}")
                if isinstance(node, ast.keyword) and node.arg == "parallel":
                    bad.append(f"{path.relative_to(PACKAGE)}:{node.lineno} parallel=")
        assert not bad, bad


def _unit(rng, n, upper=False):
    v = rng.normal(size=(n, 3))
    if upper:
        v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _latlong(rng, h=16):
    img = rng.uniform(0.0, 1.0, (h, 2 * h, 3)).astype(np.float32)
    img[3, 5] = 500.0  # a sun: the probe targets' point lights
    return img


def _env_sh_matrix(rng):
    from shbake.shading.shader import shader_class

    asset = {"/tangent_irradiance/matrix": rng.normal(size=(3, 4, 4)),
             "/sun/direction": np.array([0.0, 0.6, 0.8]), "/sun/radiance": np.ones(3),
             "/sun/solid_angle": 1e-3}  # fmt: skip
    return shader_class("tangent").from_asset(asset).shade(None, None, tangents=_unit(rng, 300))


def _ggx_integrals(rng):
    from shbake.reference.ggx import ggx_integrals

    v = _unit(rng, 40, upper=True)
    return np.stack(ggx_integrals(_latlong(rng), v, np.tile([0.0, 0.0, 1.0], (40, 1)), 0.3, 64))


def _texels(rng):
    from shbake.envmap.environment import Environment

    return Environment(_latlong(rng), "latlong").samples()


def _brute_irradiance(rng):
    from shbake.reference.irradiance import brute_force_irradiance

    d, w, r = _texels(rng)
    q = _unit(rng, 60)
    return np.stack([brute_force_irradiance(d, w, r, q, tangent=t) for t in (False, True)])


def _brute_shading(rng):
    from shbake.brdf import make_brdf
    from shbake.reference.brdf_shading import brute_force_shading

    d, w, r = _texels(rng)
    frames = np.stack([np.eye(3)] * 50)
    return brute_force_shading(d, w, r, frames, _unit(rng, 50, upper=True),
                               make_brdf("ggx", alpha=0.4))  # fmt: skip


def _brdf_evaluate(rng):
    from shbake.brdf import make_brdf

    s, v = _unit(rng, 500), _unit(rng, 500, upper=True)  # s below the horizon: zeros
    return make_brdf("ashikhmin-shirley", nu=40, nv=10).evaluate(s, v)


def _project_views(rng):
    from shbake.brdf import make_brdf
    from shbake.brdf.tabulate import project_views

    return project_views(make_brdf("phong"), _unit(rng, 20, upper=True), 2, samples=64)[0]


def _parabolic_fetch(rng):
    from shbake.texture.parabolic import fetch

    return fetch(rng.normal(size=(8, 8, 4, 3)), _unit(rng, 200, upper=True))


def _sh_targets(rng):
    from shbake.bakers.shexp_sh_targets import ShTargets

    n = np.repeat(_unit(rng, 4, upper=True), 10, axis=0)
    v = np.repeat(np.array([[0.0, 0.0, 1.0]]), 40, axis=0)
    v = (v + n) / np.linalg.norm(v + n, axis=1, keepdims=True)
    return ShTargets(v, n, np.repeat([0.2, 0.6], 20), lmax=2, samples=64).e0(_latlong(rng))


def _splitsum_prefilter(rng):
    from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain

    img = _latlong(rng)
    levels = [prefilter_chain(img, SplitSumConfig(top=16, min_size=8, alphas=(0.1, 0.5),
                                                  samples=32, prefilter=p))
              for p in ("filtered", "plain")]  # fmt: skip
    return np.concatenate([lv.ravel() for chain in levels for lv in chain])


def _shrm(rng):
    from shbake.bakers.shrm import shrm_from_directions
    from shbake.brdf.reflection import brdf_coefficients, make_reflection_brdf

    co = brdf_coefficients(make_reflection_brdf("ggx", {"alpha": 0.3}), 4, 2)
    L = rng.normal(size=(25, 3))
    dirs = _unit(rng, 300)
    return np.concatenate([co.rho.ravel()] + [shrm_from_directions(dirs, L, co, local=loc).ravel()
                                              for loc in (False, True)])  # fmt: skip


def _shrm_angular(rng):
    from shbake.bakers.shrm_angular import angular_reflection_maps
    from shbake.brdf.reflection import make_reflection_brdf

    rb = make_reflection_brdf("phong-lobe", {"s": 16})
    return angular_reflection_maps(_latlong(rng), rb, _unit(rng, 30), _unit(rng, 2, upper=True))


def _quadrature_plan(rng):
    from shbake.bakers.shexp_targets import QuadraturePlan

    n = _unit(rng, 40, upper=True)
    plan = QuadraturePlan.build(n, n, rng.uniform(0.1, 0.8, 40), 64, (16, 32))
    img = _latlong(rng)
    return np.concatenate([plan.index.astype(float), plan.weight,
                           np.ravel(plan.e0_many([img, 0.5 * img]))])  # fmt: skip


def _cube_prefilter(rng):
    from shbake.bakers.cube_prefilter import (
        cube_pyramid,
        mirror_cube,
        prefilter_level,
        reference_level,
    )
    from shbake.envmap.environment import Environment

    env = Environment(_latlong(rng), "latlong")
    cube = mirror_cube(env, 4)
    level = prefilter_level(cube_pyramid(cube), 4, 0.3, 32)
    return np.concatenate([cube.ravel(), level.ravel(), reference_level(env, 2, 0.3).ravel()])


FORMER_PRANGE = {f.__name__[1:]: f for f in (
    _env_sh_matrix, _ggx_integrals, _brute_irradiance, _brute_shading, _brdf_evaluate,
    _project_views, _parabolic_fetch, _sh_targets, _splitsum_prefilter, _shrm, _shrm_angular,
    _quadrature_plan, _cube_prefilter,
)}  # fmt: skip
"""Public calls covering the 19 kernels that ran on ``prange`` before issue 28."""


@pytest.mark.parametrize("case", sorted(FORMER_PRANGE))
def test_former_prange_kernels_do_not_depend_on_the_thread_count(monkeypatch, case):
    """Each block range is computed alone, so 1, 2 or 3 threads give the same bits (the
    conversion itself was checked against the ``prange`` kernels: see the commit)."""
    results = []
    for threads in (1, 2, 3):
        two_threads(monkeypatch, threads)
        results.append(np.asarray(FORMER_PRANGE[case](np.random.default_rng(7))))
    assert np.all(np.isfinite(results[0]))
    for r in results[1:]:
        np.testing.assert_array_equal(r, results[0])


def test_registration_hooks_wait_for_numba():
    """:func:`shbake.jit.on_numba_load`: a hook runs when the first kernel compiles (not at
    import: numba stays unloaded), and at once when numba is already registered."""
    code = (
        "import sys\n"
        "from shbake import jit\n"
        "calls = []\n"
        "jit.on_numba_load(lambda: calls.append('first'))\n"
        "import shbake.simd\n"
        "assert 'numba' not in sys.modules and calls == [], calls\n"
        "k = jit.jit(cache=False)(lambda x: x + 1)\n"
        "assert k(1) == 2 and calls == ['first'], calls\n"
        "jit.on_numba_load(lambda: calls.append('later'))\n"
        "assert calls == ['first', 'later'], calls\n"
        "print('ok')\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.stdout.strip() == "ok", p.stderr
