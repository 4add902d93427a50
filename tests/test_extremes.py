"""Stability at the extremes (``make test-extremes``): every baker on degenerate inputs.

Maps: black, constant, a one-texel 1e5 sun on a dim sky, a 1e-6 dim real map,
a tiny (4 × 8) and a large (1024 × 2048) map. Settings: lmax 0 and 64,
GGX width at both ends (SH-exp fit α 0.05 … 1, split-sum α 0.0025 … 1, GGX tables 1e-4 … 1),
exponents to 1e4, views grazing to 1e-4. Nothing non-finite in any asset,
and where a closed form exists the value is checked against it (constant map:
E = π c; black map: zeros).
"""

import numpy as np
import pytest
from helpers import map_path, write_test_exr

from shbake.bakers.env_sh import bake_env_sh
from shbake.bakers.shexp import FitConfig, FitPlan
from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
from shbake.brdf import make_brdf
from shbake.brdf.tabulate import project_views, tabulate
from shbake.envmap import load_environment
from shbake.envmap.image_io import read_image
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.env_sh import irradiance

pytestmark = pytest.mark.extremes

H = 32


def _map(kind: str, h: int = H) -> np.ndarray:
    w = 2 * h
    if kind == "black":
        return np.zeros((h, w, 3))
    if kind == "constant":
        return np.full((h, w, 3), 0.75)
    if kind == "sun":
        px = np.full((h, w, 3), 0.01)
        px[h // 4, w // 3] = 1e5
        return px
    if kind == "dim":
        px, _ = read_image(str(map_path("sunset")))
        step = max(1, px.shape[0] // h)
        return px[::step, ::step][:h, :w] * 1e-6
    raise ValueError(kind)


MAPS = ("black", "constant", "sun", "dim")


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    folder = tmp_path_factory.mktemp("extremes")
    out = {k: str(write_test_exr(folder / f"{k}.exr", _map(k))) for k in MAPS}
    out["tiny"] = str(write_test_exr(folder / "tiny.exr", _map("constant", 4)))
    big = np.full((1024, 2048, 3), 0.5, np.float32)
    big[100, 200] = 1e5
    out["large"] = str(write_test_exr(folder / "large.exr", big))
    return out


def _finite(asset):
    for name, data in asset.datasets.items():
        assert np.all(np.isfinite(np.asarray(data, float))), name


class TestEnvShExtremes:
    @pytest.mark.parametrize("kind", MAPS + ("tiny",))
    @pytest.mark.parametrize("lmax", [0, 2, 64])
    @pytest.mark.parametrize("sun", [False, True])
    def test_finite_and_closed_forms(self, maps, kind, lmax, sun):
        env = load_environment(maps[kind], quiet=True)
        if kind == "tiny" and lmax == 64:
            lmax = 1  # a 4-row map holds two bands; higher lmax is aliasing by construction
        asset, _ = bake_env_sh(env, lmax=lmax, irradiance_lmax=min(lmax, 2), sun=sun)
        _finite(asset)
        dirs = fibonacci_sphere(256)
        e = irradiance(asset, dirs)
        assert np.all(np.isfinite(e))
        if kind == "black":
            assert np.all(e == 0.0)
        if kind in ("constant", "tiny") and not sun:
            # E = π c for a constant radiance c (any lmax: only band 0 is non-zero)
            np.testing.assert_allclose(e, np.pi * 0.75, rtol=2e-3)

    def test_large_map_with_a_sun(self, maps):
        env = load_environment(maps["large"], quiet=True)
        asset, summary = bake_env_sh(env, lmax=2, sun=True)
        _finite(asset)
        assert summary["sun"]["extracted"]


class TestBrdfTableExtremes:
    @pytest.mark.parametrize(
        "model, params",
        [
            ("ashikhmin-shirley", {"nu": "1e4", "nv": "1e4"}),
            ("ashikhmin-shirley", {"nu": "1e4", "nv": "0"}),
            ("phong", {"n": "1e4"}),
            ("phong", {"n": "0"}),
            ("ggx", {"alpha_x": "1e-4", "alpha_y": "1e-4"}),
            ("ggx", {"alpha_x": "1", "alpha_y": "1"}),
        ],
    )
    def test_finite_tables_and_grazing_views(self, model, params):
        brdf = make_brdf(model, **params)
        table, _ = tabulate(brdf, 4, (8, 8), samples=64)
        assert np.all(np.isfinite(table))
        for z in (1e-1, 1e-2, 1e-3, 1e-4):
            v = np.array([[np.sqrt(1 - z * z), 0.0, z]])
            c, _ = project_views(brdf, v, 4, samples=64)
            assert np.all(np.isfinite(c)), z


class TestProbeExtremes:
    @pytest.mark.parametrize("kind", MAPS)
    @pytest.mark.parametrize("rough", [(0.05, 0.1), (0.9, 1.0)])  # GGX width α (its lowest)
    def test_shexp_fit_finite(self, maps, kind, rough):
        env = load_environment(maps[kind], quiet=True)
        config = FitConfig(alpha_min=rough[0], alpha_max=rough[1], alpha_count=3, sets=2,
                           samples=64, normals=16, views=16)  # fmt: skip
        probe = FitPlan(config, env.shape).fit(env.pixels)
        assert np.all(np.isfinite(probe.p)) and np.all(np.isfinite(probe.q))
        assert np.isfinite(probe.stats["log_rms"])

    @pytest.mark.parametrize("kind", MAPS)
    @pytest.mark.parametrize("rough", [(0.05, 0.1), (0.9, 1.0)])
    def test_splitsum_finite(self, maps, kind, rough):
        env = load_environment(maps[kind], quiet=True)
        config = SplitSumConfig(top=16, min_size=8, alphas=(rough[0] ** 2, rough[1] ** 2),
                                samples=64)  # fmt: skip
        for level in prefilter_chain(env.pixels, config):
            assert np.all(np.isfinite(level))
        if kind == "black":
            assert all(np.all(lv == 0) for lv in prefilter_chain(env.pixels, config))
