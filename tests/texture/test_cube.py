"""Cube maps (:mod:`shbake.texture.cube`): bilinear sampling exact at texel centres, second
order across edges and faces, the same bytes on any thread count; bad directions refused.
"""

import numpy as np
import pytest

from shbake.errors import ParameterError
from shbake.texture.cube import cube_directions, sample_cube


class TestSampleCube:
    def test_texel_centres_exact_and_same_as_the_input_layout(self):
        from shbake.envmap.layouts import cube_texels

        d = cube_directions(8)
        ref = cube_texels("cube-strip", 48, 8)[0].reshape(-1, 3)
        np.testing.assert_allclose(d.reshape(-1, 3), ref, atol=1e-15)
        cube = np.random.default_rng(0).normal(size=(6, 8, 8, 2))
        np.testing.assert_allclose(sample_cube(cube, d), cube, atol=1e-14)

    def test_smooth_function_second_order_across_edges(self):
        def f(x):
            return np.stack([2 * x[..., 0] + x[..., 1] ** 2, x[..., 2] * x[..., 0]], -1)

        rng = np.random.default_rng(1)
        q = rng.normal(size=(100000, 3))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        srt = np.sort(np.abs(q), 1)
        errs = []
        for size in (16, 32, 64):
            d = cube_directions(size)
            err = np.abs(sample_cube(f(d), q) - f(q)).max(1)
            corner = srt[:, 0] / srt[:, 2] > 1 - 2 / size
            errs.append(err[~corner].max())
        # away from the 8 corners the fetch is second order, seams included
        assert errs[1] < errs[0] / 3.2 and errs[2] < errs[1] / 3.2

    def test_same_bytes_on_any_thread_count_and_bad_directions_refused(self, monkeypatch):
        rng = np.random.default_rng(2)
        cube = rng.normal(size=(6, 16, 16, 3))
        q = rng.normal(size=(50000, 3))
        monkeypatch.setenv("SHBAKE_THREADS", "1")
        one = sample_cube(cube, q)
        monkeypatch.setenv("SHBAKE_THREADS", "2")
        assert sample_cube(cube, q).tobytes() == one.tobytes()
        for bad in ([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]], [[np.nan, 0.0, 1.0]], [[0.0, 1.0]]):
            with pytest.raises(ParameterError):
                sample_cube(cube, bad)


class TestCubeBilinearTaps:
    """cube_bilinear_taps: the texels and weights cube_bilinear blends, as weights (the
    least-squares fit of a chain level needs them): the weighted sum of those texels is
    :func:`sample_cube` at every direction, seams and corners included."""

    @pytest.mark.parametrize("size", [1, 2, 4, 7])
    def test_weights_read_what_sample_cube_reads(self, size):
        from shbake.texture.cube import FACE_AXES, MAX_TAPS, cube_bilinear_taps, sample_cube

        rng = np.random.default_rng(size)
        cube = rng.random((6, size, size, 1))
        d = rng.normal(size=(500, 3))
        want = sample_cube(cube, d)[:, 0]
        index, weight = np.empty(MAX_TAPS, np.int64), np.empty(MAX_TAPS)
        for k in range(len(d)):
            n = cube_bilinear_taps(size, FACE_AXES, *d[k], index, weight)
            assert weight[:n].sum() == pytest.approx(1.0)
            assert (weight[:n] * cube.reshape(-1)[index[:n]]).sum() == pytest.approx(want[k])
