"""Paths at the library's boundary (:func:`shbake.resources.path_arguments`)."""

from pathlib import Path

import pytest

from shbake.resources import path_arguments


class TestPathArguments:
    def test_path_like_reaches_the_function_as_text(self):
        @path_arguments("path", "pairs", "optional")
        def seen(path, pairs, optional=None, other=None):
            return path, pairs, optional, other

        other = Path("kept")
        got = seen(Path("a.exr"), [(Path("b.exr"), "b.h5"), ("c.exr", None)], other=other)
        assert got == ("a.exr", [("b.exr", "b.h5"), ("c.exr", None)], None, other)
        assert type(got[0]) is str and type(got[1][0][0]) is str
        assert seen(pairs=(), path="x", optional=Path("o")) == ("x", (), "o", None)

    def test_unknown_name_refused_at_import(self):
        with pytest.raises(TypeError, match="takes no argument outptu"):
            path_arguments("outptu")(lambda output: output)
