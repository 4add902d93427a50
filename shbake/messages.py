"""The lines shbake prints for people, made inert: what a file name carries is shown, not obeyed.

File names, scene names and the strings inside assets are untrusted (``docs/SECURITY.md``).
Printed raw, a name could act on the terminal that shows it: an OSC sequence
(``ESC ] 0;title BEL``) retitles it or worse, a carriage return or backspaces overwrite
what came before (a forged ``shbake:`` line), C1 codes act as escapes on some terminals,
and a bidi override (U+202E) shows the rest of the line reversed. Every error, warning and
note line and every progress description goes through :func:`printable`, which writes each
such character as its Python escape (``\\x1b``, ``\\r``, ``\\u202e``): visible and inert. The CLI
applies it where it prints (``shbake_cli.guard.one_line``, ``shbake_cli.options.info``, the
progress bars); the library's own warnings print through :func:`warn`.
"""

import sys

CONTROLS = (*range(0x00, 0x20), *range(0x7F, 0xA0))
"""C0 controls, DEL and C1 controls: Unicode category ``Cc``."""
LAYOUT_CONTROLS = (0x061C, 0x200E, 0x200F, *range(0x202A, 0x202F), *range(0x2066, 0x206A),
                   0x2028, 0x2029)  # fmt: skip
"""Bidi marks, embeddings, overrides and isolates (Unicode TR9), line and paragraph separators."""
KEPT = (0x09,)
"""Tab: only moves the cursor forward (report tables are tab-separated)."""

_ESCAPES = {c: repr(chr(c))[1:-1] for c in (*CONTROLS, *LAYOUT_CONTROLS) if c not in KEPT}
"""Each character to its escape as ``repr`` writes it (``\\x1b``, ``\\r``, ``\\u202e``)."""


def printable(text) -> str:
    """``str(text)`` with every control and bidi-layout character written as its escape.

    A newline is escaped too: one message stays one line (a multi-line report prints
    line by line).
    """
    return str(text).translate(_ESCAPES)


_run = {"quiet": False, "warnings": []}
"""The command run in progress: whether ``-q`` silences stderr, the warnings it gave so far."""


def start_run(quiet: bool = False) -> None:
    """A command run begins: no warning recorded yet; with ``quiet`` (``-q``) warnings are
    recorded (for ``--json``) but not printed."""
    _run["quiet"] = quiet
    _run["warnings"] = []


def end_run() -> None:
    """A command run ends: warnings print again. ``-q`` is that run's, not the process's: an
    in-process run (a test, a program calling ``shbake_cli.main.main``) left it set, and
    every later library warning in the process went unprinted."""
    start_run(quiet=False)


def record(message: str) -> None:
    """Remember a warning of this run (printed or not) for its ``--json`` summary."""
    if message not in _run["warnings"]:
        _run["warnings"].append(message)


def run_warnings() -> list[str]:
    """Every warning this run gave, in order (``--json`` keeps them under ``-q``)."""
    return list(_run["warnings"])


def warn(message: str, quiet: bool = False) -> None:
    """``shbake: warning: MESSAGE`` on stderr, one line: the library's warnings about an input
    (what was repaired or clamped), printed as they happen and recorded for the run's
    ``--json``; not printed under ``-q`` (:func:`start_run`). ``quiet``: an input the run
    reads again (already reported): neither printed nor recorded."""
    if quiet:
        return
    record(message)
    if not _run["quiet"]:
        print(f"shbake: warning: {printable(message)}", file=sys.stderr)
