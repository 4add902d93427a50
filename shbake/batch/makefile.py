"""Text for a Makefile fragment: each string a scene, a path or a name supplies, in the one
form GNU make and ``/bin/sh`` read back as exactly that string — or refused.

Three contexts, one routine each (``shbake plan --emit-make``, docs/SCENES.md
"Makefile safety"; ``tests/batch/test_makefile.py`` proves each against GNU make (4.3) and
``/bin/sh`` on every printable ASCII character, tab, newline, CR and non-ASCII):

* :func:`make_path` — a file name as one word of a rule (target or prerequisite);
  :func:`line_start_path` as the word a line starts with (no directive).
  ``$`` is written ``$$``; space, ``#``, ``:`` and the wildcard characters ``* ? [``
  get a backslash. make has no escape for the rest of :data:`MAKE_REFUSED`
  (``;`` starts a recipe, ``=`` a variable, ``|`` order-only prerequisites, ``%``
  a pattern rule, ``( )`` archive members, ``\\`` escapes) nor for control
  characters (tab, newline, CR…), a trailing space (make strips it) or a word
  starting with ``~`` (home folder) or ``-`` (``-lNAME`` libraries): those are
  refused with :class:`MakeNameError`.
* :func:`shell_word` — one argument of a recipe's command: a word of letters,
  digits and ``_ . / + , : @ % -`` stays as it is (unless it starts a recipe line with
  one of make's prefixes ``@ - +``), any other is POSIX single-quoted (``'`` as
  ``'\\''``); ``$`` is then written ``$$`` for make. Control characters are refused
  (a recipe is one line).
* :func:`variable_value` — shell words as the value of a make variable
  (``SHBAKE ?= …``): ``$`` as ``$$`` and ``#`` as ``\\#``; a backslash is refused
  (make reads ``\\#`` and ``\\`` before a line end specially).

A recipe therefore carries no scene text but through :func:`shell_word`: the
asset ids are built of names that match :data:`shbake.batch.scene.NAME_PATTERN`.
"""

import re
import unicodedata

from shbake.errors import ParameterError

MAKE_REFUSED = ";=|%\\()"
"""Characters GNU make cannot hold in a file name of a rule (besides control characters)."""
MAKE_ESCAPED = " #:*?["
"""Characters a backslash makes literal in a rule's file names (``$`` is doubled instead)."""
_BARE_WORD = re.compile(r"[A-Za-z0-9_./+,:@%-]+")
"""Shell words written without quotes (nothing in them is special to ``sh`` or make)."""


class MakeNameError(ParameterError):
    """A string a Makefile cannot hold: ``what`` gave it (an option), the string (as a
    Python literal: control characters escaped) and why."""

    def __init__(self, text: str, reason: str, what: str = ""):
        self.text, self.reason = text, reason
        super().__init__(f"{what + ': ' if what else ''}{text!r}: {reason}")


def _control(text: str) -> str | None:
    """The first control character (or undecodable byte) of ``text``, if any."""
    return next((c for c in text if unicodedata.category(c) in ("Cc", "Cs")), None)


def make_path(path: str) -> str:
    """``path`` as one file name of a make rule (target or prerequisite)."""
    bad = _control(path) or next((c for c in path if c in MAKE_REFUSED), None)
    if bad is not None:
        raise MakeNameError(path, f"a Makefile cannot name a file with {bad!r} in its path")
    if path == "" or path.endswith(" ") or path[0] in "~-":
        raise MakeNameError(path, "a Makefile cannot name a file that is empty, ends in a "
                            "space or starts with '~' or '-'")  # fmt: skip
    return "".join("$$" if c == "$" else "\\" + c if c in MAKE_ESCAPED else c for c in path)


def line_start_path(path: str) -> str:
    """``path`` as the first word of a rule's line (:func:`make_path`): a relative path
    gets ``./`` before it, so no file name is read as a directive (a fragment named
    ``else``, ``endif``, ``include``, ``export``…); make drops a leading ``./`` from the
    file names of rules, so it names the same file."""
    return make_path(path) if path.startswith("/") else "./" + make_path(path)


def shell_word(word: str, first: bool = False) -> str:
    """``word`` as one argument of a recipe line (quoted for ``sh``, then ``$`` for make);
    ``first``: the line's first word (make reads a leading ``@ - +`` as its own prefixes)."""
    bad = _control(word)
    if bad is not None:
        raise MakeNameError(word, f"a make recipe cannot pass {bad!r} to a command")
    if not _BARE_WORD.fullmatch(word) or first and word[0] in "@-+":
        word = "'" + word.replace("'", "'\\''") + "'"
    return word.replace("$", "$$")


def variable_value(words: list[str]) -> str:
    """Shell ``words`` as the value of a make variable that starts recipe lines (one word
    each)."""
    for w in words:
        if "\\" in w:
            raise MakeNameError(w, "a Makefile variable cannot hold '\\'")
    return " ".join(shell_word(w, i == 0).replace("#", "\\#") for i, w in enumerate(words))


def variable_name(text: str) -> str:
    """``text`` as part of a make variable name: ASCII letters and digits upper-cased, any
    other character ``_``."""
    return re.sub(r"[^A-Za-z0-9]", "_", text).upper()
