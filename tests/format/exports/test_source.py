"""The export frame (:func:`shbake.format.exports.source.frame_matrix`): with ``--frame z-up
--rotate θ`` the engine's irradiance at ``R d`` equals shbake's world irradiance at ``d``, in
three.js under node; the rotated export read in the world frame fails.
"""

import json

import numpy as np
import pytest

from shbake.batch.export import export_assets
from shbake.format.exports.source import frame_matrix, load_source, shbake_irradiance
from tests.export_checks import BAKED_FOR_NODE, TOL
from tests.export_checks import relative_error as _rel
from tests.helpers import run_node

pytestmark = BAKED_FOR_NODE


class TestFrameRoundTrip:
    """--frame z-up --rotate θ: the engine's E at R d equals shbake's world E at d."""

    @pytest.mark.parametrize("frame,deg", [("z-up", 30.0), ("y-up", -75.0)])
    def test_three_and_babylon(self, baked, dirs_file, tmp_path, frame, deg):
        R = frame_matrix(frame, deg)
        d = np.array(json.load(open(dirs_file)))
        dt = tmp_path / "dt.json"
        dt.write_text(json.dumps((d @ R.T).tolist()))
        src = load_source(baked["h5"])
        want = shbake_irradiance(src, d)  # world frame
        three = export_assets(
            [baked["h5"]], "threejs", str(tmp_path / "t.json"), frame=frame, rotate_deg=deg
        )[0]
        got = np.array(run_node("three_irradiance.mjs", three, str(dt))["irradiance"])
        assert _rel(got, want, src, d) < TOL
        # and the rotation is really applied: reading the rotated export in the world frame fails
        got_world = np.array(run_node("three_irradiance.mjs", three, dirs_file)["irradiance"])
        assert _rel(got_world, want) > 1e-3
