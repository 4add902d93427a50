"""Probe assets (:mod:`shbake.format.probe`): the α convention and range a probe was fitted
for are checked before it is shaded.
"""

import pytest

from shbake.bakers.dfg import dfg_table
from shbake.bakers.shexp import FitPlan
from tests.helpers import smooth_map
from tests.probe_cases import SMALL


class TestProbeAsset:
    def test_old_convention_refused(self):
        from shbake.errors import FormatError
        from shbake.format.asset import Asset
        from shbake.format.probe import check_probe_alpha

        old = Asset("shexp_probe", {"roughness_convention": "perceptual roughness r",
                                    "roughness_range": [0.2, 1.0]}, {})  # fmt: skip
        with pytest.raises(FormatError, match="perceptual roughness.*re-bake"):
            check_probe_alpha(old, 0.5)

    def test_alpha_outside_range_refused(self):
        from shbake.format.probe import check_probe_alpha
        from shbake.format.shexp import build_shexp_asset

        plan = FitPlan(SMALL, (32, 64))
        meta = {"path": "m.exr", "sha256": "0" * 64, "size": 1, "nonfinite_policy": "error",
                "negative_policy": "clamp"}  # fmt: skip
        asset = build_shexp_asset(plan.fit(smooth_map(32)), SMALL, dfg_table(8, 64), meta)
        assert check_probe_alpha(asset, 0.2) == 0.2 and check_probe_alpha(asset, 1.0) == 1.0
        for bad in (0.19, 1.01, float("nan")):
            with pytest.raises(ValueError, match="outside this probe's range"):
                check_probe_alpha(asset, bad)
