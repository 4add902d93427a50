"""Control characters from file names never reach the terminal (issue 27, item 15).

A name may carry an OSC sequence (``ESC ] 0;… BEL`` retitles the terminal), a carriage
return, backspace, DEL, a C1 code (``\\x9b`` is CSI on some terminals) or a bidi override
(U+202E): error, warning, ``wrote …`` and progress lines show each one escaped
(:func:`shbake.messages.printable`). The oracle is Unicode's own table (``Cc``) and the
escapes Python's ``repr`` writes.
"""

import io
import sys
import unicodedata

import numpy as np
import pytest

from shbake.messages import printable
from tests.helpers import write_test_exr

HOSTILE = "\x1b]0;pwned\x07|\r|\x08|\x7f|\x9b|\u202e|\u2066"
"""An OSC title sequence, CR, backspace, DEL, C1 CSI, a bidi override and an isolate."""
SHOWN = "\\x1b]0;pwned\\x07|\\r|\\x08|\\x7f|\\x9b|\\u202e|\\u2066"
"""The same name as the terminal must show it (repr's escapes)."""
RAW = set(HOSTILE) - set("]0;pwned|")


def assert_inert(text: str) -> None:
    """No raw control or bidi character of the name; the name shown escaped."""
    assert not RAW & set(text), sorted(RAW & set(text))
    assert SHOWN in text, text


BIDI_FORMATTING = ("LRE", "RLE", "LRO", "RLO", "PDF", "LRI", "RLI", "FSI", "PDI")
BIDI_MARKS = ("LEFT-TO-RIGHT MARK", "RIGHT-TO-LEFT MARK", "ARABIC LETTER MARK")


def test_printable_escapes_exactly_the_controls():
    # from Unicode's tables: category Cc (but tab), the explicit bidi formatting classes and
    # marks (TR9's Bidi_Control), the line and paragraph separators
    for c in map(chr, range(0x10000)):
        hostile = (
            (unicodedata.category(c) == "Cc" and c != "\t")
            or unicodedata.bidirectional(c) in BIDI_FORMATTING
            or unicodedata.name(c, "") in BIDI_MARKS
            or unicodedata.category(c) in ("Zl", "Zp")
        )
        if hostile:
            assert printable(c) == repr(c)[1:-1] and printable(c).isprintable(), hex(ord(c))
        else:
            assert printable(c) == c, hex(ord(c))
    words = "café 日本 👩\u200d💻 tab\there"  # non-ASCII names and joiners stay as they are
    assert printable(words) == words


def test_error_line(run_cli, tmp_path):
    code, _, err = run_cli("project-env", tmp_path / f"sky{HOSTILE}.exr", "-o", tmp_path / "a.h5")
    assert code == 1 and err.startswith("shbake: error:") and err.count("\n") == 1, err
    assert_inert(err)


def test_warning_and_wrote_lines(run_cli, tmp_path):
    # a map with negative pixels warns with its name; the wrote line names the output
    px = np.ones((8, 16, 3), np.float32)
    px[0, 0] = -1.0
    src = write_test_exr(tmp_path / f"sky{HOSTILE}.exr", px)
    out = tmp_path / f"env{HOSTILE}.h5"
    code, _, err = run_cli("project-env", src, "-o", out)
    assert code == 0, err
    warning, wrote = err.splitlines()
    assert warning.startswith("shbake: warning:") and "negative pixels" in warning
    assert wrote.startswith("wrote ")
    assert_inert(warning)
    assert_inert(wrote)
    assert out.exists()


def test_usage_error_line(run_cli, tmp_path):
    code, _, err = run_cli("shrm", tmp_path / "a.exr", "-o", tmp_path / "a.h5",
                           "--brdf", f"x{HOSTILE}")  # fmt: skip
    assert code == 2 and err.count("\n") == 1, err
    assert not RAW & set(err)


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_description(monkeypatch):
    from shbake_cli.options import BarProgress

    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    with BarProgress().task(f"reading {HOSTILE}", total=2) as advance:
        advance(2)
    drawn = term.getvalue()
    assert "pwned" in drawn
    # the bar's own carriage returns and cursor moves are tqdm's; the name's are escaped
    assert not (RAW - {"\r"}) & set(drawn) and "\x1b]" not in drawn
    assert "\\x1b]0;pwned\\x07" in drawn


@pytest.mark.parametrize("name", ["a\nshbake: error: forged", "a\rshbake: error: forged"])
def test_one_message_stays_one_line(run_cli, tmp_path, name):
    code, _, err = run_cli("project-env", tmp_path / name, "-o", tmp_path / "a.h5")
    assert code == 1 and err.count("\n") == 1 and "\r" not in err, err
