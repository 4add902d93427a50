"""Projection (SPEC §4, §5): white dome, round trips, ducc0 as a second implementation."""

import numpy as np
import pytest

from shbake.envmap import Environment, load_environment
from shbake.envmap.layouts import LAYOUTS, texels
from shbake.sh.basis import real_sh
from shbake.sh.kernels import convolve, kajiya_kay_kernel, lambert_kernel
from shbake.sh.projection import IMAGE_FRAME, project_latlong
from tests.helpers import map_path, synth_latlong
from tests.references import ducc0_project

ducc0 = pytest.importorskip("ducc0")


class TestWhiteDome:
    @pytest.mark.parametrize(
        "layout,shape",
        [
            ("latlong", (64, 128)),
            ("cube-strip", (192, 32)),
            ("cross-h", (96, 128)),
            ("cross-v", (128, 96)),
        ],
    )
    def test_l00_irradiance_and_tangent(self, layout, shape):
        _, _, mask = texels(layout, *shape)
        env = Environment(
            np.where(mask[:, :, None], 1.0, 0.0).astype(np.float32) * np.ones(3, np.float32), layout
        )
        L = env.project(2)
        assert L[0, 0] == pytest.approx(np.sqrt(4 * np.pi), rel=1e-12)
        n = np.random.default_rng(1).normal(size=(50, 3))
        E = real_sh(n, 2) @ convolve(L, lambert_kernel(2))
        Et = real_sh(n, 2) @ convolve(L, kajiya_kay_kernel(2))
        # Lat-long is exact (Fejér rows); cubes by exact solid-angle midpoint rule.
        tol = 1e-12 if layout == "latlong" else 1e-6
        np.testing.assert_allclose(E, np.pi, rtol=tol)
        np.testing.assert_allclose(Et, 1.0, rtol=tol)


class TestProjectLatlong:
    def test_round_trip_is_exact_for_band_limited_maps(self, random_coeffs):
        c = random_coeffs(8, seed=3)
        img = synth_latlong(c, 64)
        np.testing.assert_allclose(project_latlong(img, 8), c, atol=1e-12)
        # Projecting further finds nothing above band 8.
        assert np.abs(project_latlong(img, 12)[81:]).max() < 1e-12

    def test_fft_path_equals_table_path(self, random_coeffs):
        img = synth_latlong(random_coeffs(30, seed=4), 128).astype(np.float32)
        from shbake.sh import projection

        old = projection.FFT_MIN_LMAX
        try:
            projection.FFT_MIN_LMAX = 0
            fft = projection.project_latlong(img, 30)
            projection.FFT_MIN_LMAX = 10_000
            table = projection.project_latlong(img, 30)
        finally:
            projection.FFT_MIN_LMAX = old
        np.testing.assert_allclose(fft, table, atol=1e-11)

    @pytest.mark.parametrize("lmax", [2, 8, 30])
    def test_agrees_with_ducc0_on_a_real_map(self, lmax):
        env = load_environment(str(map_path("esplanade")), quiet=True)
        ours = env.project(lmax)
        theirs = ducc0_project(env.pixels, lmax)
        scale = np.abs(theirs).max(axis=0)
        assert (np.abs(ours - theirs).max(axis=0) / scale).max() < 1e-10

    def test_image_frame_is_a_proper_rotation(self):
        assert np.linalg.det(IMAGE_FRAME) == pytest.approx(1.0)


class TestCubeLayouts:
    @pytest.mark.parametrize("layout", [l for l in LAYOUTS if l != "latlong"])
    def test_round_trip_converges(self, layout, random_coeffs):
        # Midpoint rule with exact texel solid angles: error falls ~4× per doubling.
        c = random_coeffs(4, seed=5)
        errs = []
        for n in (16, 32, 64):
            h, w = {"cube-strip": (6 * n, n), "cross-h": (3 * n, 4 * n), "cross-v": (4 * n, 3 * n)}[
                layout
            ]
            dirs, omega, mask = texels(layout, h, w)
            img = np.zeros((h, w, 3))
            img[mask] = real_sh(dirs[mask], 4) @ c
            errs.append(np.abs(Environment(img.astype(np.float32), layout).project(4) - c).max())
        assert errs[-1] < 2e-3
        assert errs[0] / errs[1] > 3.0 and errs[1] / errs[2] > 3.0

    def test_cube_and_latlong_agree_on_the_same_scene(self, random_coeffs):
        c = random_coeffs(3, seed=6)
        n = 96
        dirs, omega, mask = texels("cube-strip", 6 * n, n)
        cube = np.zeros((6 * n, n, 3))
        cube[mask] = real_sh(dirs[mask], 3) @ c
        lat = synth_latlong(c, 96)
        a = Environment(cube.astype(np.float32), "cube-strip").project(3)
        b = Environment(lat.astype(np.float32), "latlong").project(3)
        np.testing.assert_allclose(a, b, atol=2e-4)
