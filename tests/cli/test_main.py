"""cli/main.py: what one run sets is that run's, not the process's (in-process runs: tests,
programs calling ``shbake_cli.main.main``)."""

import numpy as np
from shbake_cli.main import main

from shbake.messages import warn
from tests.helpers import write_test_exr


class TestMain:
    def test_quiet_is_the_runs(self, tmp_path, capsys):
        """After a ``--quiet`` run, library warnings print again: the flag stayed set, and a
        later export's half-float clamp warning went unprinted in whichever test xdist ran
        after one (tests/system/test_extremes.py::TestHalfFloatOverflow, clean clone)."""
        m = write_test_exr(tmp_path / "map.exr", np.full((16, 32, 3), 0.5))
        assert main(["project-env", str(m), "-o", str(tmp_path / "a.h5"), "--quiet"]) == 0
        capsys.readouterr()
        warn("after the run")
        assert capsys.readouterr().err == "shbake: warning: after the run\n"
