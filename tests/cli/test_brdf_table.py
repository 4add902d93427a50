"""``shbake brdf-table`` end to end: the table asset and its images, byte-identical reruns, bad
input in one line and no file, and the kautz preview of the table with ``--diff``.
"""

import json

import h5py
import numpy as np
import pytest

from shbake.brdf.tabulate import FIRST_LEVEL_POINTS
from tests.helpers import map_path


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
        assert "-p nu is replaced by the --vary nu axis" in summary["warnings"]
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
            (["ggx", "--vary", "alpha_x=0.1:0.5:2", "--vary", "alpha_x=0.1:0.5:2"],
             "each parameter may be varied once", 2),
            (["ggx", "--vary", "alpha=0.1:0.5:2", "--vary", "alpha_y=0.1:0.5:2"],
             "each parameter may be varied once", 2),
            (["phong", "--vary", "rho_d=0.1:0.5:2"], "rho_d is a colour", 2),
            (["lafortune", "-p", "cxy3=-10"], "lobe 3 peaks at", 2),
            (["lafortune", "-p", "n1=10000"], "lobe 1 peaks at", 2),
            (["ggx", "--vary", "alpha_x=nan:1:2"], "lo and hi must be finite", 2),
            (["ggx", "--vary", "alpha_x=0.1:inf:2"], "lo and hi must be finite", 2),
            (["ggx", "-p", "alpha_x=nan"], "alpha_x=nan is outside", 2),
            (["ggx", "--size", "1"], "sides must be in", 2),
            (["merl"], "needs a MERL", 1),
        ],
    )
    def test_bad_input_one_line_no_file(self, run_cli, tmp_path, args, match, code):
        out = tmp_path / "x.h5"
        got, _, err = run_cli("brdf-table", *args, "-o", out)
        assert got == code and match in err and err.count("\n") == 1, err
        assert list(tmp_path.iterdir()) == []

    def test_vary_an_alias(self, run_cli, tmp_path):
        """``--vary alpha=…`` (GGX's alias of alpha_x and alpha_y) varies both: each table
        equals one baked at that isotropic width."""
        from shbake.format.asset import read_asset

        common = ["--size", "4", "--lmax", "2", "--samples", "64", "--reproducible", "-q"]
        assert run_cli("brdf-table", "ggx", "-o", tmp_path / "v.h5", "--vary", "alpha=0.2:0.6:2",
                       *common)[0] == 0  # fmt: skip
        assert run_cli("brdf-table", "ggx", "-o", tmp_path / "a.h5", "-p", "alpha=0.6",
                       *common)[0] == 0  # fmt: skip
        varied = read_asset(str(tmp_path / "v.h5"))["/table"]
        single = read_asset(str(tmp_path / "a.h5"))["/table"]
        np.testing.assert_array_equal(varied[1], single)
        assert not np.array_equal(varied[0], single)

    def test_unmet_tol_names_the_samples_used(self, run_cli, tmp_path):
        """A ``--tol`` no refinement meets warns with the points per strategy the table
        used, the asset's ``samples_max``: at the least ``--max-samples``, the nested rules'
        first level, every texel stops there."""
        code, stdout, err = run_cli("brdf-table", "ggx", "-p", "alpha=0.3", "--size", 4,
                                    "--lmax", 2, "--tol", "1e-6", "--max-samples",
                                    FIRST_LEVEL_POINTS, "-o", tmp_path / "t.h5", "--json",
                                    "-q")  # fmt: skip
        assert code == 0, err
        summary = json.loads(stdout)
        assert summary["samples_max"] == FIRST_LEVEL_POINTS
        (warning,) = [w for w in summary["warnings"] if "did not reach --tol" in w]
        assert f"by {FIRST_LEVEL_POINTS} samples" in warning, warning
        assert f"raise --max-samples above {FIRST_LEVEL_POINTS}" in warning

    def test_max_samples_below_the_first_level_refused(self, run_cli, tmp_path):
        """A ``--max-samples`` below the nested rules' first level, which every texel
        integrates whole, could not take effect: a usage error naming the least value, not a
        bake that silently uses more."""
        code, out, err = run_cli("brdf-table", "ggx", "--size", 4, "--lmax", 2, "--tol", "1e-3",
                                 "--max-samples", FIRST_LEVEL_POINTS - 1, "-o",
                                 tmp_path / "t.h5")  # fmt: skip
        assert code == 2 and err.count("\n") == 1 and out == "", err
        assert f"is not in the range {FIRST_LEVEL_POINTS}<=x<=" in err, err
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
