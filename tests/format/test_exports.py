"""The export targets (:mod:`shbake.format.exports`): every name resolves, unknown ones are
refused.
"""

import pytest

from shbake.format.exports import target_module


class TestRegistry:
    """target_module: every target name resolves; unknown names are refused."""

    def test_targets(self):
        assert target_module("babylon").CUBES is target_module("gltf").CUBES
        with pytest.raises(Exception, match="unknown export target"):
            target_module("unreal")
