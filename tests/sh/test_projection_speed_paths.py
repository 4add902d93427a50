"""Issue 15: the fast projection paths give the same coefficients as before, and as ducc0.

``tests/data/projection_before.npz`` holds the results of the implementation
before issue 15 (commit 2b78de2: pair sums per row, one dot product per ``m``,
recurrence per row) on the six shared maps (``--negative keep``) and on three
random maps of odd and non-multiple-of-4 widths. The new kernels fold four
columns and two rows and block the sums differently, so the summation order
changed: agreement is asserted to 1e-12 of each channel's largest coefficient.
ducc0 is the independent implementation (SPEC §5 conversion, in
``tests/sh/test_projection.py``).
"""

from pathlib import Path

import numpy as np
import pytest

from shbake.envmap import load_environment
from shbake.envmap.repair import apply_negative_policy
from shbake.sh import projection
from shbake.sh.projection import project_latlong
from shbake.sh.rotation import SHRotation
from tests.helpers import SHARED_MAPS, map_path
from tests.references import ducc0_project

BEFORE = np.load(Path(__file__).parents[1] / "data" / "projection_before.npz")
RANDOM_MAPS = ("random37x75", "random20x42", "random33x64")


def rel_err(ours, ref):
    return float((np.abs(ours - ref).max(axis=0) / np.abs(ref).max(axis=0)).max())


@pytest.fixture(scope="module")
def shared_pixels():
    return {
        n: load_environment(str(map_path(n)), negative="keep", quiet=True).pixels
        for n in SHARED_MAPS
    }


class TestProjectLatlongAgainstBefore:
    @pytest.mark.parametrize("method", ["numba", "blas"])
    @pytest.mark.parametrize("lmax", [2, 8, 30])
    def test_shared_maps(self, shared_pixels, lmax, method):
        for name, px in shared_pixels.items():
            got = project_latlong(px, lmax, method=method)
            assert rel_err(got, BEFORE[f"{name}_lmax{lmax}"]) < 1e-12, name

    @pytest.mark.parametrize("method", ["numba", "blas"])
    @pytest.mark.parametrize("lmax", [2, 8, 30])
    @pytest.mark.parametrize("key", RANDOM_MAPS)
    def test_odd_and_unaligned_widths(self, key, lmax, method):
        img = BEFORE[f"{key}_image"]
        got = project_latlong(img, lmax, method=method)
        assert rel_err(got, BEFORE[f"{key}_lmax{lmax}"]) < 1e-12

    def test_threads_do_not_change_the_result(self, shared_pixels, monkeypatch):
        px = np.ascontiguousarray(np.tile(shared_pixels["esplanade"], (4, 4, 1)))
        monkeypatch.setenv("SHBAKE_THREADS", "1")
        one = project_latlong(px, 8)
        monkeypatch.setenv("SHBAKE_THREADS", "2")
        monkeypatch.setattr("shbake.jit.MIN_WORK_PER_THREAD", 1)
        two = project_latlong(px, 8)
        np.testing.assert_array_equal(one, two)


class TestProjectLatlongAgainstDucc0:
    @pytest.mark.parametrize("method", ["numba", "blas"])
    @pytest.mark.parametrize("lmax", [2, 8, 30])
    def test_shared_maps(self, shared_pixels, lmax, method):
        for name, px in shared_pixels.items():
            got = project_latlong(px, lmax, method=method)
            assert rel_err(got, ducc0_project(px, lmax)) < 1e-12, name

    @pytest.mark.parametrize("method", ["numba", "blas"])
    @pytest.mark.parametrize("key", RANDOM_MAPS)
    def test_odd_and_unaligned_widths(self, key, method):
        img = BEFORE[f"{key}_image"]
        assert rel_err(project_latlong(img, 8, method=method), ducc0_project(img, 8)) < 1e-12

    @pytest.mark.parametrize("nc", [1, 4])
    @pytest.mark.parametrize("shape", [(33, 64), (40, 1030)])
    def test_channel_counts(self, nc, shape):
        # The generic-channel kernels (fold, dots, latitude stage), odd and even heights.
        img = np.random.default_rng(nc).random((*shape, nc)) - 0.2
        got = project_latlong(img, 12, method="numba")
        assert rel_err(got, ducc0_project(img, 12)) < 1e-12


class TestRowSums:
    def test_quarter_and_half_folds_agree(self, shared_pixels):
        # W % 4 == 0 takes the four-column fold; W = 510 the two-column one.
        px = shared_pixels["studio"]
        full = projection.row_sums(px, 12)
        cut = projection.row_sums(np.ascontiguousarray(px[:, :510]), 12)
        direct = np.einsum(
            "hwc,wk->hck",
            px[:, :510].astype(np.float64),
            _direct_table(510, 12),
        )
        assert np.abs(cut - direct).max() < 1e-12 * np.abs(direct).max()
        assert (
            np.abs(
                full - np.einsum("hwc,wk->hck", px.astype(np.float64), _direct_table(512, 12))
            ).max()
            < 1e-12 * np.abs(full).max()
        )

    @pytest.mark.parametrize("nc", [1, 3, 4])
    @pytest.mark.parametrize("width", [1200, 1030, 1031])
    def test_column_blocks_and_channel_counts(self, nc, width):
        # Several column blocks with a partial last one (quarter fold: W/4 = 300;
        # half fold: 515 and 516 columns with the middle one of an odd width), and
        # the generic-channel path beside the unrolled RGB one, against the direct sum.
        img = np.random.default_rng(width + nc).random((6, width, nc), dtype=np.float32) - 0.3
        lmax = 13
        direct = np.einsum("hwc,wk->hck", img.astype(np.float64), _direct_table(width, lmax))
        got = projection.row_sums(img, lmax)
        assert np.abs(got - direct).max() < 1e-12 * np.abs(direct).max()

    @pytest.mark.parametrize("shape", [(300, 1030, 3), (7, 64, 1), (5, 33, 4)])
    def test_blas_path_against_the_direct_sum(self, shape):
        # Several ~4 MB chunks with a partial last one (1030 columns: 169 rows each), and
        # one chunk for small images, each against the direct einsum.
        img = np.random.default_rng(shape[1]).random(shape, dtype=np.float32) - 0.3
        direct = np.einsum("hwc,wk->hck", img.astype(np.float64), _direct_table(shape[1], 8))
        got = projection.row_sums(img, 8, method="blas")
        assert np.abs(got - direct).max() < 1e-13 * np.abs(direct).max()


class TestToWorldBlas:
    @pytest.mark.parametrize("lmax", range(9))
    def test_matches_the_rotation_recurrence(self, lmax):
        # The quadrature matrix against the Ivanic–Ruedenberg blocks of SHRotation.
        dense = SHRotation(projection.IMAGE_FRAME.T, lmax).dense()
        got = projection._to_world_blas(lmax)
        assert np.abs(got - dense).max() < 1e-14
        bands = np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
        assert np.all(got[bands[:, None] != bands[None, :]] == 0.0)


def _direct_table(w, lmax):
    phi = -2.0 * np.pi * (np.arange(w) + 0.5) / w
    cols = [np.ones(w)]
    for m in range(1, lmax + 1):
        cols += [np.cos(m * phi), np.sin(m * phi)]
    return np.stack(cols, axis=1)


class TestApplyNegativePolicy:
    """The clamp writes only the negatives (issue 15); same pixels as ``np.maximum``."""

    def test_clamp_matches_maximum_and_energy(self):
        rng = np.random.default_rng(5)
        px = (rng.random((16, 32, 3)) - 0.2).astype(np.float32)
        omega = rng.random((16, 32))
        ref = np.maximum(px, 0.0)
        energy = ((ref - px).astype(np.float64) * omega[:, :, None]).sum(axis=(0, 1))
        for inplace in (False, True):
            src = px.copy()
            out, count, change = apply_negative_policy(
                src, omega, "clamp", "x", quiet=True, inplace=inplace
            )
            assert out.tobytes() == ref.tobytes()
            assert (out is src) == inplace
            if not inplace:
                assert src.tobytes() == px.tobytes()
            assert count == int(np.any(px < 0, axis=2).sum())
            np.testing.assert_allclose(change, energy, rtol=1e-12)

    def test_non_contiguous_pixels(self):
        px = (np.random.default_rng(6).random((8, 8, 4)) - 0.5).astype(np.float32)
        view = px[:, :, :3]  # RGB of RGBA: not contiguous
        out, _, _ = apply_negative_policy(view, np.ones((8, 8)), "clamp", "x", True, True)
        assert np.array_equal(px[:, :, :3], np.maximum(view, 0)) and out.min() >= 0

    def test_no_negatives_returns_the_input(self):
        px = np.ones((4, 8, 3), np.float32)
        out, count, change = apply_negative_policy(px, np.ones((4, 8)), "clamp", "x")
        assert out is px and count == 0 and not change.any()
