"""Kautz shading of BRDF tables (:mod:`shbake.shading.brdf_table`): the preview pass against
brute-force shading, its per-pixel kernels against the definition evaluated pixel by pixel.
The command: ``tests/cli/test_brdf_table.py``."""

import json
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import map_path
from tests.kautz_accuracy import LMAXES, MAPS, kautz_errors

EXPECTED = json.loads((Path(__file__).parent / "kautz_accuracy_expected.json").read_text())


class TestKautzAccuracy:
    # esplanade (the sun) in make test; the other maps repeat the study (make test-all)
    @pytest.mark.parametrize(
        "name", [n if n == "esplanade" else pytest.param(n, marks=pytest.mark.slow) for n in MAPS]
    )
    def test_error_vs_brute_force_decreases_with_lmax(self, name):
        got = kautz_errors(map_path(name))
        errs = [got[l] for l in LMAXES]
        assert all(a > b for a, b in zip(errs, errs[1:], strict=False)), errs
        for l in LMAXES:
            assert got[l] == pytest.approx(EXPECTED[name][str(l)], rel=0.02)


class TestKautzKernels:
    """The pass's per-pixel kernels against the definition evaluated pixel by pixel
    (SHRotation per frame, the parabolic fetch, numpy dot products)."""

    @pytest.fixture(scope="class")
    @classmethod
    def scene(cls):
        from shbake.brdf.sampling import fibre_frames
        from shbake.preview.passes import sphere_points
        from shbake.sh.rotation import SHRotation, block_offsets
        from shbake.texture.parabolic import fetch

        lmax = 4
        n, t, v, _ = sphere_points(23)  # 400-odd pixels: a partial last block
        frames = fibre_frames(n, t)
        views = np.einsum("pij,pj->pi", frames, v)
        views[:, 2] = np.maximum(views[:, 2], 0.0)
        rng = np.random.default_rng(4)
        table = rng.normal(size=(6, 5, (lmax + 1) ** 2, 3))
        L = rng.normal(size=((lmax + 1) ** 2, 3))
        c = fetch(table, views)
        rot = [SHRotation(R, lmax) for R in frames]
        L_local = np.stack([r.apply(L) for r in rot])
        q = np.einsum("pic,pic->pc", L_local, c)
        c_world = np.stack([r.apply(ck, transpose=True) for r, ck in zip(rot, c, strict=True)])
        off = block_offsets(lmax)
        return dict(lmax=lmax, frames=frames, views=views, table=table, L=L, off=off,
                    L_local=L_local, q=q, c_world=c_world)  # fmt: skip

    def test_full_frame(self, scene):
        from shbake.shading.brdf_table import shade_full

        s = scene
        out = np.empty((len(s["frames"]), 3))
        shade_full(s["frames"], s["views"], s["table"], s["L"], s["lmax"], s["off"], out)
        np.testing.assert_allclose(out, s["q"], rtol=0, atol=1e-12 * np.abs(s["q"]).max())

    def test_rotated_lighting_and_fixed_light_frame(self, scene):
        from shbake.shading.brdf_table import lookup_dot, rotate_lighting

        s = scene
        L_local = np.empty_like(s["L_local"])
        rotate_lighting(s["frames"], s["L"], s["lmax"], s["off"], L_local)
        np.testing.assert_allclose(L_local, s["L_local"], rtol=0, atol=1e-13)
        out = np.empty((len(s["frames"]), 3))
        lookup_dot(s["views"], s["table"], L_local, out)
        np.testing.assert_allclose(out, s["q"], rtol=0, atol=1e-12 * np.abs(s["q"]).max())

    def test_fixed_view_frame(self, scene):
        from shbake.shading.brdf_table import dot_world, rotate_coeffs_to_world

        s = scene
        cw = np.empty_like(s["c_world"])
        rotate_coeffs_to_world(s["frames"], s["views"], s["table"], s["lmax"], s["off"], cw)
        np.testing.assert_allclose(cw, s["c_world"], rtol=0, atol=1e-13)
        out = np.empty((len(s["frames"]), 3))
        dot_world(cw, s["L"], out)
        np.testing.assert_allclose(out, s["q"], rtol=0, atol=1e-12 * np.abs(s["q"]).max())
