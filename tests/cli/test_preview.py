"""``preview --diff`` shows progress with its real total (issue 32, Deliver 4): the
brute-force reference is integrated in blocks of pixels and counted against the number of
pixels the sphere covers, on stderr, when stderr is a terminal (a pseudo-terminal here).

Oracle: the pixel count of the sphere from the preview's geometry as docs/CONVENTIONS.md
defines it (pixel centres ``x = 2(j+½)/N − 1``, ``y = 1 − 2(i+½)/N``, inside the unit
disc), written out here; the old bar drew ``0pass [00:00, ?pass/s]`` with no total.
"""

import numpy as np

from tests.helpers import map_path
from tests.terminal import bar_counts, run_on_terminal


def disc_pixels(size: int) -> int:
    c = 2 * (np.arange(size) + 0.5) / size - 1
    return int(np.count_nonzero(c[None, :] ** 2 + c[:, None] ** 2 < 1))


def test_preview_diff_counts_the_reference_pixels(tmp_path, run_cli):
    asset = tmp_path / "e.h5"
    assert run_cli("project-env", map_path("studio"), "-o", asset, "-q")[0] == 0
    code, drawn = run_on_terminal("preview", asset, "-o", tmp_path / "p.exr", "--size", "24",
                                  "--diff")  # fmt: skip
    assert code == 0, drawn
    counts, totals = bar_counts(drawn, "pixel")
    assert totals == {disc_pixels(24)}, drawn
    assert max(counts) == disc_pixels(24) and len(counts) > 2, drawn  # it moved, to the end


def test_no_bar_off_a_terminal(tmp_path, run_cli):
    asset = tmp_path / "e.h5"
    assert run_cli("project-env", map_path("studio"), "-o", asset, "-q")[0] == 0
    code, _, err = run_cli("preview", asset, "-o", tmp_path / "p.exr", "--size", "16", "--diff")
    assert code == 0 and "pixel" not in err and "\r" not in err, err
