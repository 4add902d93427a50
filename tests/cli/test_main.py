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


def _strict_json(text: str):
    """``json.loads`` that refuses ``NaN`` and ``Infinity`` (not JSON; JavaScript refuses)."""
    import json

    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


class TestJsonSummary:
    def test_non_finite_numbers_are_null(self, tmp_path, capsys):
        """An all-black map: the ``--report`` study's log error is undefined (0/0)."""
        m = write_test_exr(tmp_path / "black.exr", np.zeros((16, 32, 3)))
        args = ["-o", str(tmp_path / "z.h5"), "--normals", "8", "--views", "4", "--samples", "16"]
        assert main(["probe-fit", str(m), *args, "--report", "--json", "-q"]) == 0
        summary = _strict_json(capsys.readouterr().out)
        assert summary["samples_study"][0]["target_log_rms"] is None

    def test_python_warnings_are_listed_also_under_quiet(self, tmp_path, capsys, monkeypatch):
        """A numpy warning raised inside the bake (a float32 overflow, put into the map's
        loading: shbake's own sums no longer overflow on any finite map): one line on stderr
        after the run, and in the summary's ``warnings`` with and without ``-q``
        (docs/CLI.md ``--json``)."""
        import shbake.batch.project_env as project_env

        def overflowing(*args, **kwargs):
            np.full(2, 3e38, dtype=np.float32).sum()
            return load(*args, **kwargs)

        load = project_env.load_environment
        monkeypatch.setattr(project_env, "load_environment", overflowing)
        m = write_test_exr(tmp_path / "map.exr", np.full((16, 32, 3), 0.5))
        for quiet in ([], ["-q"]):
            assert main(["project-env", str(m), "-o", str(tmp_path / "h.h5"), "--json",
                         *quiet]) == 0  # fmt: skip
            out, err = capsys.readouterr()
            listed = [w for w in _strict_json(out)["warnings"] if "overflow" in w]
            assert listed == ["RuntimeWarning: overflow encountered in reduce"]
            assert (err.count("overflow") == 1) is not bool(quiet)
