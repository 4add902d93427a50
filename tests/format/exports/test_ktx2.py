"""KTX2 exports (:mod:`shbake.format.exports.ktx2`) read by ktx-parse (three.js's KTX2 parser)
under node: header and mip chain, level 0 the mirror cube, the DFG table. The byte layout
against the KTX 2.0 specification: ``test_ktx2_layout.py``.
"""

import base64
import json
import os
import shutil

import numpy as np
import pytest

from shbake.bakers.env_sh import bake_env_sh
from shbake.batch.export import export_assets
from shbake.envmap import load_environment
from shbake.format.asset import write_asset
from shbake.format.exports.source import frame_matrix
from tests.export_checks import SHARED
from tests.export_checks import read_ktx2 as _ktx2

pytestmark = pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")


class TestKtx2:
    """ktx2.write: read by ktx-parse (three.js's KTX2 parser); level 0 = the mirror cube."""

    @pytest.fixture(scope="class")
    @classmethod
    def written(cls, tmp_path_factory):
        d = tmp_path_factory.mktemp("ktx")
        path = os.path.join(SHARED, "hdri", "esplanade.exr")
        env = load_environment(path, quiet=True)
        asset, _ = bake_env_sh(env, lmax=2, provenance={"input_abspath": os.path.abspath(path)})
        h5 = str(d / "e.h5")
        write_asset(h5, asset)
        files = export_assets(
            [h5],
            "ktx2",
            str(d / "e.ktx2"),
            frame="z-up",
            rotate_deg=20.0,
            size=16,
            floor=1,
            samples=32,
        )
        return {"files": files, "env": env}

    def test_header_and_mip_chain(self, written):
        r = _ktx2(written["files"][0])
        assert (r["vkFormat"], r["typeSize"], r["faceCount"], r["supercompressionScheme"]) == (
            97,
            2,
            6,
            0,
        )
        assert r["pixelWidth"] == 16 and r["levelCount"] == 5  # 16, 8, 4, 2, 1
        assert [len(base64.b64decode(b)) for b in r["levels"]] == [
            6 * n * n * 8 for n in (16, 8, 4, 2, 1)
        ]
        assert r["colorModel"] == 1 and r["transferFunction"] == 1
        assert json.loads(r["keyValue"]["shbake.roughness"])[0] == 0.0

    def test_level0_is_the_mirror_cube(self, written):
        from shbake.bakers.cube_prefilter import mirror_cube, mirror_supersample

        r = _ktx2(written["files"][0])
        lv0 = np.frombuffer(base64.b64decode(r["levels"][0]), "<f2").reshape(6, 16, 16, 4)
        env = written["env"]
        want = mirror_cube(env, 16, mirror_supersample(env, 16), frame_matrix("z-up", 20.0))
        np.testing.assert_allclose(lv0[..., :3], want, rtol=1e-3, atol=1e-6)  # half-float rounding
        assert np.all(lv0[..., 3] == 1.0)

    def test_dfg_table(self, written):
        from shbake.bakers.dfg import dfg_table

        r = _ktx2(written["files"][1])
        assert (r["vkFormat"], r["faceCount"], r["levelCount"]) == (83, 1, 1)
        t = np.frombuffer(base64.b64decode(r["levels"][0]), "<f2").reshape(
            r["pixelHeight"], r["pixelWidth"], 2
        )
        np.testing.assert_allclose(t, np.transpose(dfg_table(), (1, 0, 2)), rtol=2e-3, atol=1e-4)
