"""The cube prefilter (:mod:`shbake.bakers.cube_prefilter`) with filtered importance sampling:
no speck the converged reference lacks (plain importance sampling shows some), and faces
that meet without a seam.
"""

import os

import numpy as np
import pytest

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap import load_environment
from tests.export_checks import SHARED


def _fireflies(img: np.ndarray) -> np.ndarray:
    """Texels brighter (luminance) than 4× the median of their 3×3 neighbourhood (within a face)."""
    y = img @ REC709_LUMINANCE
    f, n, _ = y.shape
    pad = np.pad(y, ((0, 0), (1, 1), (1, 1)), mode="edge")
    win = np.stack([pad[:, i : i + n, j : j + n] for i in range(3) for j in range(3)], -1)
    return y > 4.0 * np.median(win, axis=-1)


class TestMirrorSupersample:
    """mirror_supersample: a mirror level samples the map as finely as its texels, no finer."""

    def test_sub_texels_per_side(self):
        from shbake.bakers.cube_prefilter import mirror_supersample

        env = load_environment(os.path.join(SHARED, "hdri", "forest.exr"), quiet=True)
        # a face spans a quarter of the 512 columns: 128 map texels across
        assert [mirror_supersample(env, n) for n in (16, 32, 100, 128, 256)] == [8, 4, 2, 1, 1]

    def test_level0_is_the_map_read_bilinearly(self):
        """Where the cube is finer than the map, level 0 holds the map read bilinearly at each
        texel's direction (test-side lat-long bilinear), not a box filter of sub-texels."""
        from shbake.bakers.cube_prefilter import cube_directions, prefilter_chain
        from tests.engine_browser import latlong_bilinear

        env = load_environment(os.path.join(SHARED, "hdri", "forest.exr"), quiet=True)
        levels, roughness = prefilter_chain(env, size=128, floor=128)
        d, _ = cube_directions(128)
        want = latlong_bilinear(env.pixels, d.reshape(-1, 3)).reshape(levels[0].shape)
        assert roughness == [0.0]
        np.testing.assert_allclose(levels[0], want, rtol=1e-12, atol=1e-12)


class TestFireflies:
    """prefilter_level with filtered importance sampling: no speck the converged reference lacks."""

    @pytest.fixture(scope="class")
    @classmethod
    def sunny(cls):
        from shbake.bakers.cube_prefilter import cube_pyramid, mirror_cube

        env = load_environment(os.path.join(SHARED, "hdri", "esplanade.exr"), quiet=True)
        return env, cube_pyramid(mirror_cube(env, 64))

    @pytest.mark.parametrize("alpha", [0.2, 0.3, 0.4])
    def test_no_new_fireflies(self, sunny, alpha):
        from shbake.bakers.cube_prefilter import prefilter_level, reference_level

        env, pyr = sunny
        ref = reference_level(env, 32, alpha)
        fis = prefilter_level(pyr, 32, alpha, samples=256)
        plain = prefilter_level(pyr, 32, alpha, samples=256, fis=False)
        new_fis = _fireflies(fis) & ~_fireflies(ref)
        new_plain = _fireflies(plain) & ~_fireflies(ref)
        print(
            f"\nalpha {alpha}: fireflies FIS {int(new_fis.sum())}, "
            f"point sampling {int(new_plain.sum())}"
        )
        assert new_fis.sum() == 0
        assert new_plain.sum() > 0  # the test can fail: plain importance sampling shows specks

    def test_faces_meet_without_seam(self, sunny):
        """Texels either side of a cube edge differ no more than neighbours inside a face."""
        from shbake.bakers.cube_prefilter import cube_directions, prefilter_level

        _, pyr = sunny
        img = prefilter_level(pyr, 16, 0.3, samples=128)
        d, _ = cube_directions(16)
        flat, y = d.reshape(-1, 3), (img @ REC709_LUMINANCE).reshape(-1)
        face = np.repeat(np.arange(6), 256)
        cos = flat @ flat.T
        np.fill_diagonal(cos, -1)
        nb = np.argmax(cos, axis=1)
        jump = np.abs(np.log(y / y[nb]))
        across = face != face[nb]
        assert jump[across].max() <= 1.5 * jump[~across].max()
