"""Babylon.js ``.env`` exports (:func:`shbake.format.exports.babylon.write_env`): the layout
read as Babylon's ``GetEnvInfo`` reads it, the sun beside it, RGBD's range clamped with one
warning.
"""

import json

import numpy as np
import pytest

from shbake.batch.export import export_assets
from shbake.format.exports.source import load_source


class TestBabylonEnv:
    """babylon.write_env: Babylon's .env layout (``environmentTextureTools``), read here as
    ``GetEnvInfo``/``CreateRadianceImageDataArrayBufferViews`` read it; the rendering is
    checked in Babylon itself by ``tests/system/test_engine_render.py``."""

    @staticmethod
    def _read(path: str) -> tuple[dict, bytes]:
        data = open(path, "rb").read()
        assert data[:8] == bytes([0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36])
        end = data.index(b"\0", 8)
        return json.loads(data[8:end].decode("ascii")), data[end + 1 :]

    def test_layout_and_the_sun_beside_it(self, sky_asset, tmp_path):
        out = str(tmp_path / "s.env")
        written = export_assets([sky_asset["h5"]], "babylon", out, size=16, floor=4, samples=8)
        assert written == [out, str(tmp_path / "s_lights.gltf")]  # the asset has a sun
        info, payload = self._read(out)
        assert info["version"] == 2 and info["width"] == 16 and info["imageType"] == "image/png"
        mips = info["specular"]["mipmaps"]
        assert len(mips) == 6 * (4 + 1)  # 16² … 1², as Babylon requires
        assert [m["position"] for m in mips] == list(
            np.cumsum([0] + [m["length"] for m in mips])[:-1]
        )
        assert sum(m["length"] for m in mips) == len(payload)
        assert all(payload[m["position"] : m["position"] + 8] == b"\x89PNG\r\n\x1a\n" for m in mips)
        # alpha = 1 at 4² (level 2): lod = s log2(16 alpha) reaches 2 at alpha = 1
        assert info["specular"]["lodGenerationScale"] == pytest.approx(2 / 4)
        assert info["shbake"]["roughness_lod_mapping"] == "babylon"
        assert info["shbake"]["specular_roughness"][2:] == [1.0, 1.0, 1.0]
        assert set(info["irradiance"]) == {"x", "y", "z", "xx", "yy", "zz", "yz", "zx", "xy"}
        lights = json.load(open(tmp_path / "s_lights.gltf"))
        assert lights["extensions"]["KHR_lights_punctual"]["lights"][0]["type"] == "directional"

    def test_rgbd_range_is_clamped_with_one_warning(self, sky_asset, tmp_path, capfd):
        from shbake.format.exports.babylon import write_env

        src = load_source(sky_asset["h5"])
        levels = [np.full((6, n, n, 3), 0.5) for n in (4, 2, 1)]
        levels[0][0, 0, 0] = 1000.0
        out = str(tmp_path / "c.env")
        write_env(src, out, levels, [0.0, 1.0, 1.0], "babylon", "left-handed")
        err = capfd.readouterr().err
        assert err.count("shbake: warning:") == 1 and "RGBD (.env) maximum 255" in err
        info, _ = self._read(out)
        assert info["specular"]["lodGenerationScale"] == pytest.approx(1 / 2)
