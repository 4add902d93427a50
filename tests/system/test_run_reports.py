"""What a run says and where its files land (issue 32, Deliver 3 and 5).

Progress bars carry real totals and move (read from a pseudo-terminal, as a user sees them);
``-q --json`` keeps the warnings; a ``wrote`` line names every file the run wrote; an
export's side files sit in a folder of their own; the extracted sun is reported; ``--png``
writes a PNG beside every EXR of ``brdf-table`` and ``shrm``. Oracles: the files on disk
(walked), geometry written out in the test (lat-long cell centres, solid angles), the EXRs
read back with OpenImageIO.
"""

import json
import os
import re

import numpy as np
import OpenImageIO as oiio
import pytest

from tests.helpers import map_path, write_test_exr
from tests.terminal import bar_counts, run_on_terminal

REC709 = np.array([0.2126, 0.7152, 0.0722])
"""Rec.709 luminance weights (ITU-R BT.709), written out here as the oracle."""


class TestProgressOnATerminal:
    def test_brdf_table_counts_the_views_it_integrates(self, tmp_path):
        # issue 32: `0%| 0/1 table` for over a minute. A 12×10 table integrates the views
        # of one quadrant of the parabolic map: 6 × 5 of them.
        args = ["-o", tmp_path / "t.h5", "--size", "12x10", "--lmax", "2", "--samples", "64"]
        code, drawn = run_on_terminal("brdf-table", "ggx", *args)
        assert code == 0, drawn
        counts, totals = bar_counts(drawn, "view")
        assert totals == {30}, drawn
        assert max(counts) == 30 and len(counts) > 2, drawn  # it moved, to the end

    def test_no_bar_when_stderr_is_not_a_terminal(self, run_cli, tmp_path):
        code, _, err = run_cli("brdf-table", "ggx", "-o", tmp_path / "t.h5", "--size", "4",
                               "--lmax", "1", "--samples", "16")  # fmt: skip
        assert code == 0 and "\r" not in err and "view/s" not in err, err
        assert [line.split()[0] for line in err.splitlines()] == ["wrote", "error:"], err


def map_with_negative_pixel(path):
    """8 × 16 map of ones with pixel (0, 0) at −1."""
    px = np.ones((8, 16, 3), np.float32)
    px[0, 0] = -1.0
    return write_test_exr(path, px)


class TestWarnings:
    def test_quiet_json_keeps_the_warnings(self, run_cli, tmp_path):
        src = map_with_negative_pixel(tmp_path / "sky.exr")
        code, out, err = run_cli("project-env", src, "-o", tmp_path / "a.h5", "-q", "--json")
        assert code == 0 and err == "", err
        warnings = json.loads(out)["warnings"]
        assert any("clamped 1 negative pixels" in w for w in warnings), warnings

    def test_negative_clamp_names_its_unit_and_is_silent_when_chosen(self, run_cli, tmp_path):
        src = map_with_negative_pixel(tmp_path / "sky.exr")
        code, _, err = run_cli("project-env", src, "-o", tmp_path / "a.h5")
        assert code == 0, err
        # ∫L dω before the clamp: 4π of ones, less 2 ω₀ for the −1 texel of row 0, whose
        # solid angle is ω₀ = (2π/16)(1 − cos(π/8)); the clamp adds ω₀
        w0 = 2 * np.pi / 16 * (1 - np.cos(np.pi / 8))
        share = 100 * w0 / (4 * np.pi - 2 * w0)
        assert f"changed by {share:+.3g} %, {share:+.3g} %, {share:+.3g} % of the map's" in err
        code, _, err = run_cli("project-env", src, "-o", tmp_path / "b.h5", "--negative", "clamp")
        assert code == 0 and "warning" not in err, err


def listed_files(wrote_line: str) -> tuple[set[str], dict[str, int]]:
    """What a ``wrote MAIN (…); also A, B, N files in F/`` line names: (files, folder counts)."""
    main = wrote_line.split()[1]
    files, folders = {main}, {}
    if "; also " in wrote_line:
        for part in wrote_line.split("; also ", 1)[1].split(", "):
            m = re.fullmatch(r"(\d+) files in (.+)/", part)
            if m:
                folders[m.group(2)] = int(m.group(1))
            else:
                files.add(part)
    return files, folders


def files_under(folder) -> set[str]:
    return {os.path.join(d, f) for d, _, names in os.walk(folder) for f in names}


SUN_ROW, SUN_COLUMN = 20, 100
"""The sun's texel of the 64 × 128 test map: elevation 90 − 180 (20.5/64) = 32.34°, azimuth
360 (100.5/128) = 282.66° (u × 360°)."""
SUN_RGB = np.array([1.0, 0.8, 0.6])


@pytest.fixture(scope="module")
def sunny(tmp_path_factory):
    """A 64 × 128 map, sky 0.2 grey, a 2 × 2-texel sun of 5·10⁴ × SUN_RGB."""
    px = np.full((64, 128, 3), 0.2, np.float32)
    px[SUN_ROW : SUN_ROW + 2, SUN_COLUMN : SUN_COLUMN + 2] = 5e4 * SUN_RGB
    return write_test_exr(tmp_path_factory.mktemp("map") / "sunny.exr", px)


class TestFilesAndSun:
    def test_export_in_its_folder_and_wrote_names_every_file(self, run_cli, sunny, tmp_path):
        out = tmp_path / "sky.h5"
        code, _, err = run_cli("project-env", sunny, "-o", out, "--extract-sun", "--exr-dir",
                               tmp_path / "maps", "--png", "--export", "gltf", "--export",
                               "threejs", "--report")  # fmt: skip
        assert code == 0, err
        assert sorted(os.listdir(tmp_path)) == ["maps", "sky-gltf", "sky-threejs", "sky.h5"]
        # --report measures the glTF's cube chain as Babylon.js reads it (docs/CLI.md)
        assert f"{out}: glossy chain 256² to 8² (6 levels, 512 samples, baked in " in err
        assert (tmp_path / "sky-gltf" / "sky.gltf").exists()
        assert os.listdir(tmp_path / "sky-threejs") == ["sky.json"]
        gltf_side = [f for f in os.listdir(tmp_path / "sky-gltf") if f.endswith(".png")]
        assert len(gltf_side) > 3, gltf_side
        wrote = [line for line in err.splitlines() if line.startswith("wrote ")]
        assert len(wrote) == 1, err
        files, folders = listed_files(wrote[0])
        on_disk = files_under(tmp_path)
        counted = {f for f in on_disk if os.path.dirname(f) in folders}
        assert files | counted == on_disk and not files & counted, (wrote, sorted(on_disk))
        for folder, count in folders.items():
            assert count == len(os.listdir(folder)), folder

    def test_sun_in_report_and_json(self, run_cli, sunny, tmp_path):
        code, out, err = run_cli("project-env", sunny, "-o", tmp_path / "a.h5", "--extract-sun",
                                 "--report", "--json")  # fmt: skip
        assert code == 0, err
        sun = json.loads(out)["sun"]
        theta = np.pi * (SUN_ROW + 1) / 64  # the 2 × 2 sun's centre
        phi = 2 * np.pi * (SUN_COLUMN + 1) / 128
        assert sun["elevation_deg"] == pytest.approx(90 - np.degrees(theta), abs=1.0)
        assert sun["azimuth_deg"] == pytest.approx(np.degrees(phi), abs=1.0)
        st = np.sin(theta)
        direction = [st * np.sin(phi), np.cos(theta), -st * np.cos(phi)]  # SPEC §3 lat-long
        np.testing.assert_allclose(sun["direction"], direction, atol=0.02)
        np.testing.assert_allclose(sun["colour"], SUN_RGB / (SUN_RGB @ REC709), rtol=0.01)
        # irradiance at normal incidence: the sun texels' radiance × their solid angle
        rows = np.arange(SUN_ROW, SUN_ROW + 2)
        band = np.cos(np.pi * rows / 64) - np.cos(np.pi * (rows + 1) / 64)
        omega = 2 * (2 * np.pi / 128) * band  # two texels per row
        assert sun["intensity"] == pytest.approx(5e4 * (SUN_RGB @ REC709) * omega.sum(), rel=0.02)
        line = next(x for x in err.splitlines() if x.startswith("sun: direction"))
        assert f"elevation {sun['elevation_deg']:.1f}°" in line and "intensity" in line


def read_oiio(path) -> tuple[np.ndarray, list[str]]:
    """An image's pixels and channel names, as OpenImageIO reads them (EXR: names sorted)."""
    img = oiio.ImageInput.open(str(path))
    try:
        return img.read_image(), list(img.spec().channelnames)
    finally:
        img.close()


class TestPng:
    def test_brdf_table_png_beside_each_band(self, run_cli, tmp_path):
        d = tmp_path / "bands"
        args = ["-o", tmp_path / "t.h5", "--size", "8", "--lmax", "2", "--samples", "64"]
        code, _, err = run_cli("brdf-table", "ggx", *args, "--exr-dir", d, "--png")
        assert code == 0, err
        assert sorted(os.listdir(d)) == ["band0.exr", "band0.png", "band1.exr", "band1.png",
                                         "band2.exr", "band2.png", "sheet.png"]  # fmt: skip
        for l in range(3):
            pixels, names = read_oiio(d / f"band{l}.exr")  # texture row 0 first
            exr = pixels[:, :, [names.index(f"m{m}") for m in range(-l, l + 1)]]
            png = read_oiio(d / f"band{l}.png")[0]
            k = 2 * l + 1
            assert exr.shape == (8, 8, k) and png.shape == (12, k * 10 + 2, 3)
            for i in range(k):  # m = i − l: red where positive, blue where negative
                tile = png[2:10, 2 + 10 * i : 10 + 10 * i][::-1]
                strong = np.abs(exr[:, :, i]) > 0.05 * np.abs(exr).max()
                assert np.all((tile[..., 0] > tile[..., 2])[strong] == (exr[:, :, i] > 0)[strong])

    def test_shrm_png_beside_each_cube(self, run_cli, tmp_path):
        d = tmp_path / "exr"
        code, _, err = run_cli("shrm", str(map_path("city")), "-o", tmp_path / "o.h5", "--brdf",
                               "microfacet", "-p", "sigma=0.4", "--face-size", "8",
                               "--exr-dir", d, "--png")  # fmt: skip
        assert code == 0, err
        names = sorted(os.listdir(d))
        exrs = [n for n in names if n.endswith(".exr")]
        assert names == sorted(exrs + [n[:-4] + ".png" for n in exrs]), names
        refl_png, refl_exr = (read_oiio(d / f"reflection.{e}")[0] for e in ("png", "exr"))
        assert refl_png.shape == refl_exr.shape == (48, 8, 3)
        assert f"; also {len(names)} files in {d}/" in err, err


class TestBrdfTableReportTimes:
    def test_estimates_are_anchored_to_the_measured_bake(self, run_cli, tmp_path):
        """Issue 32: ``--report`` predicted 305 s for a 67 s bake (per-view projection time
        × views, without the refinement the bake does). Each setting's estimate is now the
        measured bake's seconds scaled by its measured cost relative to the chosen one, so
        the chosen setting's estimate is the bake's own time."""
        args = ["-o", tmp_path / "t.h5", "--size", "16", "--lmax", "4", "--samples", "64"]
        code, out, err = run_cli("brdf-table", "phong", *args, "--report", "--json")
        assert code == 0, err
        summary = json.loads(out)
        rows = summary["report"]
        chosen_lmax = next(r for r in rows["lmax"] if r["lmax"] == 4)
        chosen_res = next(r for r in rows["resolution"] if r["resolution"] == 16)
        assert chosen_lmax["est_table_seconds"] == pytest.approx(summary["seconds"], rel=1e-12)
        assert chosen_res["est_table_seconds"] == pytest.approx(summary["seconds"], rel=1e-12)
        estimates = [r["est_table_seconds"] for r in rows["lmax"] + rows["resolution"]]
        assert all(np.isfinite(e) and e > 0 for e in estimates), estimates
