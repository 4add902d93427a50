"""Contact sheets and the display transform (:mod:`shbake.preview.contact_sheet`): the fixed
error scale, ACES as Narkowicz's published fit, ``preview --display aces``.
"""

import json

import numpy as np
import pytest

from shbake.format.images import aces_filmic, tonemap
from shbake.preview.contact_sheet import ERROR_SCALE, beyond_scale


class TestContactSheet:
    def test_fixed_error_scale(self):
        """The fraction beyond the fixed scale counts the pixels whose relative luminance
        error exceeds ±10 %, whatever the largest error is."""
        assert ERROR_SCALE == 0.10
        ref = np.ones((4, 5, 3))
        res = ref.copy()
        res[0, :2] *= 1.2  # +20 %: beyond
        res[1, 0] *= 0.85  # −15 %: beyond
        res[2, 0] *= 1.05  # inside
        mask = np.ones((4, 5), bool)  # the reference's mean luminance is 1
        assert beyond_scale(res, ref, mask) == pytest.approx(3 / 20)

    def test_aces_is_narkowicz_fit(self):
        """Narkowicz's published curve (2016) at x = 0.6·radiance, per channel, through sRGB."""
        radiance = np.array([0.0, 0.18, 1.0, 4.0, 100.0])
        x = 0.6 * radiance
        fit = np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0, 1)
        np.testing.assert_allclose(aces_filmic(radiance), fit, rtol=0, atol=1e-15)
        # his curve's values: 0 → 0, large → 1 (2.51/2.43 > 1, clipped)
        assert aces_filmic(np.array([0.0]))[0] == 0.0 and aces_filmic(np.array([1e6]))[0] == 1.0
        rgb = np.array([[4.0, 1.0, 0.25]])
        srgb = tonemap(rgb, exposure=1.0, display="aces")
        lin = aces_filmic(rgb)
        expect = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
        np.testing.assert_allclose(srgb, expect, atol=1e-15)

    def test_preview_display_option(self, tmp_path, run_cli):
        """``preview --display aces``: the summary names it and the PNG is the ACES curve of
        the EXR (reinhard's differs)."""
        import OpenImageIO as oiio

        from tests.helpers import map_path

        asset = tmp_path / "e.h5"
        assert run_cli("project-env", map_path("studio"), "-o", asset, "-q")[0] == 0
        pngs = {}
        for display in ("reinhard", "aces"):
            out = tmp_path / f"p-{display}.exr"
            code, stdout, err = run_cli("preview", asset, "-o", out, "--size", "16", "--png",
                                        "--display", display, "--json", "-q")  # fmt: skip
            assert code == 0, err
            assert json.loads(stdout)["display"] == display
            exr = oiio.ImageBuf(str(out)).get_pixels(oiio.FLOAT)[..., :3]
            pngs[display] = oiio.ImageBuf(str(tmp_path / f"p-{display}.png")).get_pixels(
                oiio.UINT8)[..., :3]  # fmt: skip
            lin = aces_filmic(exr * _exposure(exr)) if display == "aces" else None
            if lin is not None:
                srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
                assert np.abs(pngs[display].astype(int) - np.round(srgb * 255)).max() <= 1
        assert np.abs(pngs["aces"].astype(int) - pngs["reinhard"].astype(int)).max() > 10


def _exposure(img: np.ndarray) -> float:
    """0.18 / geometric-mean luminance of the non-zero pixels (docs/CONVENTIONS.md)."""
    lum = np.maximum(img.astype(np.float64), 0) @ np.array([0.2126, 0.7152, 0.0722])
    return 0.18 / float(np.exp(np.mean(np.log(lum[lum > 0]))))
