"""The library call of ``shbake project-env`` (:mod:`shbake.batch.project_env`) as a program
calls it: paths as :class:`pathlib.Path` as well as ``str``."""

import numpy as np

from shbake.batch.project_env import project_environment
from shbake.format.asset import read_asset
from tests.helpers import write_test_exr


class TestProjectEnvironment:
    def test_path_like_arguments(self, tmp_path):
        """``pathlib.Path`` map, output and ``--exr-dir`` bake what the same ``str`` paths do
        (not a ``TypeError`` from the image reader), and the summary and the asset name the
        files as text."""
        pixels = np.linspace(0.1, 2.0, 8 * 16 * 3).reshape(8, 16, 3)
        sky = write_test_exr(tmp_path / "sky.exr", pixels)
        text = project_environment(str(sky), str(tmp_path / "a.h5"), quiet=True)
        path = project_environment(sky, tmp_path / "b.h5", exr_dir=tmp_path / "maps",
                                   map_size=4, quiet=True)  # fmt: skip
        assert (path["output"], text["output"]) == (str(tmp_path / "b.h5"), str(tmp_path / "a.h5"))
        a, b = read_asset(str(tmp_path / "a.h5")), read_asset(str(tmp_path / "b.h5"))
        assert b.attrs["source_path"] == a.attrs["source_path"]
        assert b.attrs["source_sha256"] == a.attrs["source_sha256"]
        np.testing.assert_array_equal(b["/lighting/sh"], a["/lighting/sh"])
        assert any((tmp_path / "maps").iterdir())
