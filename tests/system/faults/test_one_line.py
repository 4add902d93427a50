"""No traceback for odd inputs, and warnings never add lines to an error (issue 11, items 8, 9)."""

import os

import numpy as np
import pytest

from tests.faults import assert_failed, shbake, unchanged


class TestOneLine:
    """Items 8 and 9: no traceback for odd inputs; warnings never add lines to an error."""

    def test_non_utf8_list(self, run_cli, box):
        (box / "list.txt").write_bytes(b"\xff\xfe map.exr\n")
        assert_failed(run_cli("probe-fit", "--list", box / "list.txt"), fragment="UTF-8")

    @pytest.mark.parametrize("option", ["--list", "--merl"])
    @pytest.mark.parametrize("what", ["missing", "symlink-loop"])
    def test_unreadable_list_or_merl_names_the_reason(self, run_cli, box, option, what):
        """Read errors of the probe list and the MERL file said ``(None)`` instead of why."""
        path = box / "x.txt"
        if what == "symlink-loop":
            os.symlink(box / "y.txt", path)
            os.symlink(path, box / "y.txt")
        args = (["probe-fit", "--list", path] if option == "--list"
                else ["brdf-table", "merl", "--merl", path, "-o", box / "t.h5"])  # fmt: skip
        with unchanged(box):
            msg = assert_failed(run_cli(*args))
        assert "None" not in msg
        assert ("no such file" if what == "missing" else "symbolic links") in msg

    @pytest.mark.parametrize("args", [
        ["preview", "{env}", "-o", "{box}/p.exr", "--roughness", "nan"],
        ["export", "{env}", "--to", "threejs", "-o", "{box}/x.json", "--sun-radius", "nan"],
        ["probe-fit", "{map}", "--out-dir", "{box}/d", "--floor", "nan"],
        ["shrm", "{map}", "-o", "{box}/o.h5", "--brdf", "phong", "--eps", "inf"],
        ["tradeoff", "env_sh", "--map", "{map}", "--tol", "nan", "-o", "{box}/t.png"],
    ])  # fmt: skip
    def test_nan_option_refused(self, run_cli, box, args):
        """click's range check compares, and every comparison with NaN is false: NaN passed
        every float option (and was then ignored or propagated)."""
        args = [a.format(env=box / "env.h5", map=box / "map.exr", box=box) for a in args]
        with unchanged(box):
            msg = assert_failed(run_cli(*args), code=2)
        assert "not a finite number" in msg or "is not in the range" in msg, msg

    def test_scheduler_not_a_url(self, run_cli, box):
        result = run_cli("probe-fit", box / "map.exr", "--out-dir", box / "d", "--scheduler",
                         "not a url")  # fmt: skip
        assert_failed(result, code=2, fragment="--scheduler")
        assert not (box / "d").exists()

    def test_json_stdout_full(self, box):
        with open("/dev/full", "w") as full:
            r = shbake("project-env", box / "map.exr", "-o", box / "e2.h5", "--json",
                       stdout=full, timeout=60)  # fmt: skip
        assert_failed(r, fragment="stdout")

    def test_stdout_closed(self, box):
        """``shbake … >&-``: a run that prints nothing on stdout succeeds; ``--json`` is one
        line, exit 1, and nothing is written (it was a traceback and the asset written)."""
        def closed():
            os.close(1)

        assert shbake("project-env", box / "map.exr", "-o", box / "c1.h5", "-q",
                      preexec=closed, timeout=60) == (0, "", "")  # fmt: skip
        with unchanged(box):
            r = shbake("project-env", box / "map.exr", "-o", box / "c2.h5", "--json", "-q",
                       preexec=closed, timeout=60)  # fmt: skip
        assert_failed(r, fragment="stdout is closed")

    def test_warnings_then_error_is_one_line(self, capfd):
        import warnings

        from shbake_cli.guard import run

        from shbake.errors import InputError

        def call():
            warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
            np.float32(3e38) * np.float32(10)
            raise InputError("bad\nthings " + "x" * 2000)

        code = run(call, [])
        _, err = capfd.readouterr()
        assert_failed((code, "", err))
        assert len(err.splitlines()) == 1 and len(err) < 500

    def test_truncated_plan_cache_entry_rebuilt(self, tmp_path):
        from shbake.batch import plan_cache

        p = tmp_path / "plan-x.npz"
        p.write_bytes(b"PK\x03\x04 truncated")
        assert plan_cache._load(p) is None
