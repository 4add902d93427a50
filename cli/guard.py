"""One place that turns everything a run can raise into one line and an exit status.

``run(call)`` installs the signal handlers (:mod:`shbake.signals`), runs the command
inside one output transaction (:mod:`shbake.format.atomic`), records warnings
(numpy, numba) instead of printing them as they come, and maps the outcome:

=======  ===================================================================
status   meaning
=======  ===================================================================
0        success (recorded warnings summarised on stderr, one line each)
1        :class:`~shbake.errors.ShbakeError`, ``OSError``, ``MemoryError`` or
         any other failure: one line ``shbake: error: …``
2        usage error (click)
130/143  SIGINT / SIGTERM: ``shbake: error: interrupted`` (also when what fails
         is a consequence of the signal, e.g. numba after an interrupted compile)
=======  ===================================================================

No traceback is printed unless ``SHBAKE_DEBUG=1``.
"""

import errno
import os
import sys
import warnings

import click

from shbake import messages, resources, signals
from shbake.errors import ShbakeError
from shbake.format import atomic
from shbake.messages import printable

MAX_MESSAGE = 400
"""Characters of an error message kept (arrays are never printed in full)."""
MAX_WARNINGS = 3
"""Distinct warnings summarised after a successful run."""


class Interrupted(Exception):
    """A run stopped by SIGINT or SIGTERM (raised past click, which would print a blank line)."""


def one_line(text) -> str:
    """A message as one bounded line: control characters escaped first
    (:func:`shbake.messages.printable`: a name's ``\\r`` or ``ESC`` is shown, not obeyed,
    and a line break is ``\\n``), then runs of spaces and tabs collapsed."""
    text = " ".join(printable(text).split())
    return text if len(text) <= MAX_MESSAGE else text[: MAX_MESSAGE - 1] + "…"


def message_of(e: BaseException) -> str:
    """The one-line message of a failure."""
    if isinstance(e, ShbakeError):
        return one_line(e)
    if isinstance(e, MemoryError):
        return one_line(
            f"out of memory (budget {resources.human(resources.memory_budget())}); lower the "
            "sizes, lmax or sample counts, or set --max-memory"
        )
    if isinstance(e, OSError):
        return one_line(atomic.os_error_message(e))
    if isinstance(e, UnicodeError):
        return one_line(f"text is not valid UTF-8 ({e.reason})")
    return one_line(f"internal error: {type(e).__name__}: {e} (SHBAKE_DEBUG=1 shows the traceback)")


def guarded_invoke(invoke):
    """Call ``invoke()`` (a command body) as one transaction; interrupts become
    :class:`Interrupted` so that click does not handle them."""
    try:
        with atomic.transaction():
            result = invoke()
            signals.raise_if_interrupted()
            return result
    except KeyboardInterrupt:
        raise Interrupted() from None


QUIET_CATEGORIES = (DeprecationWarning, PendingDeprecationWarning, FutureWarning,
                    ImportWarning, ResourceWarning)  # fmt: skip
"""Library housekeeping warnings that say nothing about the user's run: not shown."""


class _PythonWarnings:
    """Python warnings (numpy's overflow, …) of a run, as shbake's own: each kind recorded
    once as it happens (:func:`shbake.messages.record`, so ``--json`` lists it, also under
    ``-q``) and printed after a successful run, the first :data:`MAX_WARNINGS` kinds (a
    failed run prints its one error line alone)."""

    def __init__(self):
        self.seen: list[str] = []

    def __call__(self, message, category, filename, lineno, file=None, line=None):
        if issubclass(category, QUIET_CATEGORIES):
            return
        text = f"{category.__name__}: {one_line(str(message))[:160]}"
        if text not in self.seen:
            self.seen.append(text)
            messages.record(text)

    def summarise(self, quiet: bool) -> None:
        if quiet:
            return
        for text in self.seen[:MAX_WARNINGS]:
            click.echo(f"shbake: warning: {text}", err=True)
        if len(self.seen) > MAX_WARNINGS:
            click.echo(f"shbake: warning: and {len(self.seen) - MAX_WARNINGS} more kinds",
                       err=True)  # fmt: skip


def _interrupted() -> int:
    """Remove the temporaries, print the one line (unless the watcher does), 130/143."""
    atomic.abort_active()
    if signals.claim_finish():
        signals.finish_message()
    return signals.exit_code()


def _error(msg: str) -> None:
    try:
        click.echo(f"shbake: error: {msg}", err=True)
    except OSError:
        pass


class _ClosedStdout:
    """Standing for a stdout the shell closed (``shbake … >&-``: Python's ``sys.stdout`` is
    ``None``): writing is the one-line error of a stdout that refuses writes (``--json``),
    a run that prints nothing there is unaffected."""

    def write(self, text: str) -> int:
        raise OSError(errno.EBADF, "stdout is closed")

    def flush(self) -> None:
        pass


def replace_closed_streams() -> None:
    """``sys.stdout`` / ``sys.stderr`` of a process started with them closed (``None``):
    :class:`_ClosedStdout`, and ``/dev/null`` for stderr (nothing can be shown)."""
    if sys.stdout is None:
        sys.stdout = _ClosedStdout()
    if sys.stderr is None:
        sys.stderr = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115 - the process's


def run(call, argv) -> int:
    """Run ``call()`` (the click group's ``main``); return the exit status."""
    signals.install()
    quiet = "-q" in argv or "--quiet" in argv
    messages.start_run(quiet)
    code = 0
    python_warnings = _PythonWarnings()
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = python_warnings
        try:
            try:
                call()
            except (Interrupted, KeyboardInterrupt):
                raise
            except click.exceptions.Abort:
                raise KeyboardInterrupt from None
        except (Interrupted, KeyboardInterrupt):
            return _interrupted()
        except click.exceptions.UsageError as e:
            _error(one_line(e.format_message()))
            return 2
        except click.exceptions.Exit as e:
            return e.exit_code
        except click.exceptions.ClickException as e:
            _error(one_line(e.format_message()))
            return 1
        except BaseException as e:  # noqa: BLE001 - the one place every failure ends
            if signals.received() is not None and not isinstance(e, SystemExit):
                return _interrupted()  # a failure caused by a swallowed interrupt
            if isinstance(e, SystemExit):
                return e.code if isinstance(e.code, int) else 1
            if os.environ.get("SHBAKE_DEBUG"):
                import traceback

                traceback.print_exc()
            _error(message_of(e))
            _drain_stdout()
            return 1
        try:
            sys.stdout.flush()
        except OSError as e:
            _silence_stdout()
            _error(f"cannot write to stdout ({e.strerror or type(e).__name__})")
            return 1
        python_warnings.summarise(quiet)
    return code


def _drain_stdout() -> None:
    """Flush stdout after an error; if that fails too, silence it (no exit-time traceback)."""
    try:
        sys.stdout.flush()
    except (OSError, ValueError):
        _silence_stdout()


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's last flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
