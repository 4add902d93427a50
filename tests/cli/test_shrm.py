"""``shbake shrm`` end to end: bad input in one line and no file, all energy kept, an
unreachable ``--eps`` refused before the bake, ``--json`` and ``--exr-dir``.
"""

import json
import os

import numpy as np
import pytest

from shbake.brdf.reflection import F_LIMIT, brdf_coefficients, make_reflection_brdf
from tests.helpers import map_path, write_test_exr


def small_map(folder, name="small.exr"):
    """A 16 × 32 lat-long map (its bake's cost is the BRDF's, not the map's)."""
    y = np.linspace(1.0, 2.0, 16, dtype=np.float32)[:, None, None]
    return write_test_exr(folder / name, np.tile(y, (1, 32, 3)))


class TestCLI:
    @pytest.mark.parametrize(
        "args,code,msg",
        [
            # every parameter outside its range (the range may depend on another) is a usage
            # error: exit 2 (docs/CLI.md)
            (["--eps", "0"], 2, "--eps"),
            (["--eps", "1"], 2, "--eps"),
            (["--eps", "-0.5"], 2, "--eps"),
            (["--F", "500"], 2, "--F"),
            (["--P", "99"], 2, "--P"),
            (["--face-size", "3"], 2, "--face-size"),
            (["--face-size", "100000"], 2, "--face-size"),
            (["--face-size", "1024", "--P", "16"], 2, "lower --face-size or --P"),
            (["--brdf", "microfacet", "-p", "sigma=-1"], 2, "sigma"),
            (["--brdf", "nope"], 2, "unknown BRDF"),
            (["--brdf", "ggx", "-p", "alpha_x=0.1"], 2, "isotropic"),
            (["--brdf", "phong-lobe", "--P", "2"], 2, "radially symmetric"),
            (["--view", "0,0,0"], 2, "view"),
            (["--F", "x"], 2, "F"),
        ],
    )
    def test_bad_input_one_line_no_file(self, run_cli, tmp_path, args, code, msg):
        out = tmp_path / "o.h5"
        rc, _, err = run_cli("shrm", str(map_path("city")), "-o", out, "--quiet", *args)
        assert rc == code
        assert msg in err and err.count("\n") == 1 and err.startswith("shbake: error:")
        assert not out.exists() and os.listdir(tmp_path) == []

    def test_all_energy_kept_writes_its_own_asset(self, run_cli, tmp_path):
        # phong-lobe at F 64 keeps all of the BRDF energy: 1 − captured rounds below 0
        # (−2e-12), which the asset's [0, 1] range refused (issue 27, item 16)
        out = tmp_path / "o.h5"
        rc, stdout, err = run_cli("shrm", small_map(tmp_path), "-o", out, "--brdf", "phong-lobe",
                                  "--F", "64", "--face-size", "4", "--json", "--quiet")  # fmt: skip
        assert rc == 0, err
        from shbake.format.shrm import read_shrm

        assert read_shrm(str(out)).F == 64
        assert json.loads(stdout)["eps_brdf"] == 0.0

    def test_unreachable_eps_refused_before_the_bake(self, run_cli, tmp_path):
        # Kajiya–Kay p = 32 keeps all but ~2.5e-5 of its energy at F 64, P 16: --eps 1e-6 is
        # refused as the planner refuses it (one line, the best reachable, nothing written)
        out = tmp_path / "o.h5"
        spec = ["--brdf", "kajiya-kay", "-p", "kd=0", "-p", "ks=1", "-p", "p=32"]
        rc, _, err = run_cli("shrm", small_map(tmp_path), "-o", out, *spec, "--eps", "1e-6")
        assert rc == 2 and err.count("\n") == 1, err
        assert "F ≤ 64, P ≤ 16" in err and not out.exists()
        # the best reachable, from the band energies at the limits (not the order rule)
        rb = make_reflection_brdf("kajiya-kay", {"kd": 0.0, "ks": 1.0, "p": 32.0})
        co = brdf_coefficients(rb, F_LIMIT, 16)
        kept = co.band_energy().sum(axis=(0, 1)) / co.total
        assert f"leaves {1.0 - kept.min():.3g} of the BRDF energy out" in err
        # with the orders given, the same tolerance bakes (and says it is not reached)
        rc, stdout, err = run_cli("shrm", small_map(tmp_path), "-o", out, *spec, "--eps", "1e-6",
                                  "--F", "4", "--P", "2", "--face-size", "4", "--json",
                                  "-q")  # fmt: skip
        assert rc == 0, err
        assert json.loads(stdout)["eps_reached"] is False and out.exists()

    def test_bake_json_and_exr(self, run_cli, tmp_path):
        out = tmp_path / "o.h5"
        rc, stdout, err = run_cli(
            "shrm", str(map_path("city")), "-o", out, "--brdf", "microfacet", "-p", "sigma=0.4",
            "--face-size", "16", "--exr-dir", tmp_path / "exr", "--json", "--quiet",
        )  # fmt: skip
        assert rc == 0, err
        summary = json.loads(stdout)
        assert summary["F"] == 5 and summary["P"] == 2 and out.exists()
        assert sorted(os.listdir(tmp_path / "exr")) == [
            "reflection.exr", "shrm_p0.exr", "shrm_p1.exr", "shrm_p2.exr",
        ]  # fmt: skip


class TestShrmSettings:
    @pytest.mark.parametrize(("view", "unit"), [((1e308, 1e308, 1e308), (1.0, 1.0, 1.0)),
                                                ((1e-320, 0.0, 0.0), (1.0, 0.0, 0.0)),
                                                ((0.0, -3.0, 4.0), (0.0, -0.6, 0.8))])  # fmt: skip
    def test_view_of_any_finite_magnitude(self, view, unit):
        """``--view`` is checked and normalised before the bake: a huge or subnormal vector
        was turned into zeros or NaN by its norm and refused after the bake."""
        from shbake.batch.shrm import shrm_settings

        got = shrm_settings(F=4, P=2, view=view).view
        np.testing.assert_allclose(got, np.array(unit) / np.linalg.norm(unit), rtol=1e-15)
