"""Unity exports (:mod:`shbake.format.exports.unity`): ``SphericalHarmonicsL2`` as Unity's SRP
packs and evaluates it (SHA/SHB/SHC), x mirrored.
"""

import json

import numpy as np
import pytest

from shbake.batch.export import export_assets
from shbake.format.exports.source import load_source
from shbake.sh.windows import fibonacci_sphere
from tests.export_checks import N_DIRS


class TestUnity:
    """unity.write: SphericalHarmonicsL2 as Unity's SRP packs it (SHA/SHB/SHC), x mirrored."""

    def test_packed_probe_gives_e_over_pi(self, sky_asset):
        out = str(sky_asset["dir"] / "u.unity.json")
        doc = json.load(open(export_assets([sky_asset["h5"]], "unity", out)[0]))
        sh = np.array(doc["SphericalHarmonicsL2"])  # sh[c, i]
        # SHCoefficients.GetSHA/GetSHB/GetSHC, then SHEvalLinearL0L1 + SHEvalLinearL2
        sha = np.stack([sh[:, 3], sh[:, 1], sh[:, 2], sh[:, 0] - sh[:, 6]], -1)
        shb = np.stack([sh[:, 4], sh[:, 5], 3 * sh[:, 6], sh[:, 7]], -1)
        shc = sh[:, 8]
        d = fibonacci_sphere(N_DIRS)
        src = load_source(sky_asset["h5"])
        n = d * [-1, 1, 1]  # Unity's frame: x mirrored

        def shade(nn):
            x, y, z = nn[:, 0], nn[:, 1], nn[:, 2]
            a = np.stack([x, y, z, np.ones_like(x)], -1) @ sha.T
            b = np.stack([x * y, y * z, z * z, z * x], -1) @ shb.T
            return a + b + (x * x - y * y)[:, None] * shc[None]

        from shbake.sh.basis import real_sh

        want = real_sh(d, 2) @ src.irradiance9 / np.pi
        assert np.abs(shade(n) - want).max() < 1e-12 * np.abs(want).max()
        assert np.abs(shade(d) - want).max() > 1e-3 * np.abs(want).max()  # frame not mirrored
        assert np.abs(np.pi * shade(n) - want).max() > 1e-3 * np.abs(want).max()
        assert doc["sun"]["intensity_lux"] == pytest.approx(np.pi * doc["sun"]["intensity_builtin"])
