"""The kautz preview pass against brute-force shading, and the brdf-table CLI."""

import json
from pathlib import Path

import h5py
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


class TestBrdfTableCli:
    def test_table_asset_and_images(self, run_cli, tmp_path):
        out = tmp_path / "t.h5"
        code, stdout, err = run_cli(
            "brdf-table",
            "ashikhmin-shirley",
            "-p",
            "nu=24",
            "-p",
            "nv=8",
            "-p",
            "Rs=0.9,0.8,0.5",
            "--lmax",
            2,
            "--size",
            16,
            "--samples",
            256,
            "--vary",
            "nu=10:40:3",
            "--exr-dir",
            tmp_path / "img",
            "-o",
            out,
            "--json",
            "-q",
        )
        assert code == 0, err
        summary = json.loads(stdout)
        with h5py.File(out) as f:
            assert f.attrs["kind"] == "brdf_table"
            t = f["/table"]
            assert t.shape == (3, 3, 16, 16, 9) and t.dtype == np.float32
            assert json.loads(t.attrs["axes"]) == ["channel", "nu", "row", "col", "coeff"]
            assert np.all(np.isfinite(t[()]))
            assert "bake_seconds" in t.attrs and t.attrs["error_estimate"] > 0
            np.testing.assert_allclose(f["/axes/nu"][()], [10, 25, 40])
        assert summary["shape"] == [3, 3, 16, 16, 9]
        for l in range(3):
            assert (tmp_path / "img" / f"band{l}.exr").exists()
        assert (tmp_path / "img" / "sheet.png").exists()

    def test_reproducible_is_byte_identical(self, run_cli, tmp_path):
        args = [
            "brdf-table",
            "ggx",
            "-p",
            "alpha=0.4",
            "--lmax",
            2,
            "--size",
            8,
            "--samples",
            128,
            "--reproducible",
            "-q",
        ]
        assert run_cli(*args, "-o", tmp_path / "a.h5")[0] == 0
        first = (tmp_path / "a.h5").read_bytes()
        assert run_cli(*args, "-o", tmp_path / "a.h5")[0] == 0
        assert (tmp_path / "a.h5").read_bytes() == first

    @pytest.mark.parametrize(
        "args,match,code",
        [
            (["cook"], "'cook' is not one of 'lambert', 'phong'", 2),
            (["ggx", "-p", "beta=1"], "allowed: F0, alpha_x, alpha_y, correlated, alpha", 2),
            (["ggx", "-p", "alpha=2"], "outside", 2),
            (["phong", "-p", "rho_d=0.7", "-p", "rho_s=0.7"], "energy", 2),
            (["ggx", "--lmax", 17], "17 is not in the range 0<=x<=16", 2),
            (["ggx", "--vary", "alpha=0:1"], "NAME=lo:hi:N", 2),
            (["ggx", "--size", "1"], "sides must be in", 2),
            (["merl"], "needs a MERL", 1),
        ],
    )
    def test_bad_input_one_line_no_file(self, run_cli, tmp_path, args, match, code):
        out = tmp_path / "x.h5"
        got, _, err = run_cli("brdf-table", *args, "-o", out)
        assert got == code and match in err and err.count("\n") == 1, err
        assert list(tmp_path.iterdir()) == []

    def test_preview_kautz_with_diff(self, run_cli, tmp_path):
        env, table = tmp_path / "e.h5", tmp_path / "t.h5"
        assert run_cli("project-env", map_path("forest"), "--lmax", 4, "-o", env, "-q")[0] == 0
        assert (
            run_cli(
                "brdf-table",
                "ggx",
                "-p",
                "alpha=0.5",
                "--size",
                16,
                "--samples",
                256,
                "-o",
                table,
                "-q",
            )[0]
            == 0
        )
        code, stdout, err = run_cli(
            "preview",
            env,
            "--pass",
            "kautz",
            "--table",
            table,
            "--size",
            24,
            "--diff",
            "-o",
            tmp_path / "k.exr",
            "--json",
        )
        assert code == 0, err
        s = json.loads(stdout)
        assert set(s["modes"]) == {"full", "fixed_light", "fixed_view"}
        assert s["relative_rms_error"] < 0.1


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
