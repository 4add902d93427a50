"""SIGINT and SIGTERM: stop within about a second wherever the run is, leave nothing behind.

:func:`install` (called by the ``shbake`` entry point) sets Python-level handlers that
raise ``KeyboardInterrupt`` in the main thread, and a watcher thread fed by
:func:`signal.set_wakeup_fd`: CPython's C handler writes the signal number there at once,
even while the main thread is inside a numba kernel or an HDF5 write that holds no
Python frame. A ``KeyboardInterrupt`` that lands where Python cannot raise it (a finaliser,
a ctypes callback while numba compiles) is dropped silently and whatever fails after it
is reported as the interrupt (:func:`received` is set). The main thread normally unwinds,
its transaction (:mod:`shbake.format.atomic`) removes every temporary, and the CLI prints
``shbake: error: interrupted`` and exits 130 (SIGINT) or 143 (SIGTERM). If it has not
finished within :data:`GRACE_SECONDS` (a long native kernel), the watcher removes the
temporaries itself, prints the same line and ends the process with ``os._exit``.
Forked children reset the handlers and ask the kernel to kill them with their parent
(``PR_SET_PDEATHSIG``).

Pool workers (:func:`worker_init`) ignore SIGINT (the terminal sends it to the whole
process group; the parent decides), ask the kernel to send them SIGTERM when the process
they were forked from exits (the pool's fork server, which exits with the command:
:mod:`shbake.batch.workers`), for whatever reason, ``kill -9`` of the command included,
and answer SIGTERM at once from their
watcher thread: remove the temporaries of their open transactions and ``os._exit(143)``,
even inside a numba kernel. A worker therefore never outlives its parent by more than
the time a thread needs to wake, and leaves no temporary behind.
"""

import os
import signal
import sys
import threading
from contextlib import contextmanager

GRACE_SECONDS = 1.0
"""How long the main thread has to clean up before the watcher does it and exits."""
EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}

_received: list[int] = []
_deferring: list[bool] = []  # non-empty inside deferred()
_grace = GRACE_SECONDS
_quiet = False  # pool workers: the parent prints the one line
_finished = threading.Event()
_cleanups: list = []
_finishing = threading.Lock()
_installed = False


def received() -> int | None:
    """The first signal received (``None`` if none)."""
    return _received[0] if _received else None


def exit_code() -> int:
    """130 for SIGINT, 143 for SIGTERM."""
    return EXIT_CODES.get(received() or signal.SIGINT, 130)


def raise_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if a signal arrived (loops over chunks call this;
    a transaction calls it before committing, so a swallowed interrupt never commits)."""
    if _received:
        raise KeyboardInterrupt


def _handler(signum, frame):
    if not _received:
        _received.append(signum)
    if not _deferring:
        raise KeyboardInterrupt


@contextmanager
def deferred():
    """Run a block that an interrupt must not cut in two (a transaction's commit: every
    output moved or none): a signal that arrives inside it is recorded, and raised as
    ``KeyboardInterrupt`` when the block has ended. The watcher's grace period still
    bounds the wait."""
    _deferring.append(True)
    try:
        yield
    finally:
        _deferring.pop()
    raise_if_interrupted()


def _unraisable(hook):
    """``sys.unraisablehook`` wrapper: the ``KeyboardInterrupt`` that :func:`_handler`
    raised inside a finaliser or a ctypes callback (llvmlite calls back into Python while
    numba compiles) cannot propagate; Python would print ``Exception ignored`` and go on.
    The signal is recorded, so the run still stops (:func:`raise_if_interrupted`, the
    watcher's grace period): the print is dropped, every other unraisable is passed on."""

    def unraisable(info):
        if _received and isinstance(info.exc_value, KeyboardInterrupt):
            return
        hook(info)

    return unraisable


def _watch(fd: int) -> None:
    while True:
        try:
            data = os.read(fd, 64)
        except InterruptedError:
            continue
        except OSError:
            return
        sigs = [b for b in data if b in EXIT_CODES]
        if sigs:
            break
    if not _received:
        _received.append(sigs[0])
    if _finished.wait(_grace):
        return
    if not _finishing.acquire(blocking=False):
        return  # the main thread is reporting; it exits by itself
    for cleanup in _cleanups:
        cleanup()
    if not _quiet:
        finish_message()
    os._exit(exit_code())


def on_interrupt(cleanup) -> None:
    """Have the watcher call ``cleanup()`` before it ends the process (the output layer
    registers the removal of every open transaction's temporaries,
    :func:`shbake.format.atomic.abort_active`), so this module imports no other."""
    if cleanup not in _cleanups:
        _cleanups.append(cleanup)


def finish_message() -> None:
    """Write the one line of an interrupted run; on a terminal it first erases the line (a
    progress bar the watcher interrupted inside a kernel is still drawn there)."""
    try:
        erase = b"\r\x1b[K" if os.isatty(2) else b""
        os.write(2, erase + b"shbake: error: interrupted\n")
    except OSError:
        pass


def claim_finish() -> bool:
    """The main thread's turn to report an interrupt (``False``: the watcher does it)."""
    ok = _finishing.acquire(timeout=5.0)
    _finished.set()
    return ok


def _child_after_fork() -> None:
    global _installed
    _installed = False
    _received.clear()
    try:
        signal.set_wakeup_fd(-1)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    except ValueError:
        pass
    die_with_parent()


def die_with_parent(sig: int = signal.SIGKILL, parent: int | None = None) -> None:
    """Ask Linux to send ``sig`` when the parent exits (``PR_SET_PDEATHSIG``). With
    ``parent`` (its pid), a parent that died before the request ends this process now."""
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(sig))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if parent is not None and os.getppid() != parent:
        os.kill(os.getpid(), sig)


def ignored_during_teardown() -> None:
    """After the run, while its fork server stops (seconds at most): a late SIGINT/SIGTERM
    is ignored, so that teardown finishes (the server's socket folder removed) and prints
    no traceback; :func:`exit_quietly_on_signal` follows."""
    for sig in EXIT_CODES:
        signal.signal(sig, signal.SIG_IGN)


def exit_quietly_on_signal() -> None:
    """After the run: a late SIGINT/SIGTERM (during interpreter shutdown) ends the process
    with 130/143 and no ``Exception ignored`` noise."""
    for sig, code in EXIT_CODES.items():
        signal.signal(sig, lambda s, f, code=code: os._exit(code))


def _ignore(signum, frame):
    """A worker's Python-level handler: the watcher thread does the work."""


def worker_init(parent: int) -> None:
    """Initialiser of pool worker processes (module docstring): the parent handles SIGINT,
    SIGTERM removes the worker's temporaries and ends it at once (from the watcher thread,
    so also inside a numba kernel), and the worker gets SIGTERM when the process it was
    forked from (``parent``, its pid) exits; its warnings are not printed (they would
    interleave with the parent's one-line messages)."""
    global _grace, _quiet
    import warnings

    warnings.simplefilter("ignore")  # a worker's stderr is the user's terminal: one-line rule
    _grace, _quiet = 0.0, True
    install()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _ignore)
    die_with_parent(signal.SIGTERM, parent)


def install() -> bool:
    """Install the handlers and the watcher (main thread only; once per process)."""
    global _installed
    if _installed or threading.current_thread() is not threading.main_thread():
        return False
    r, w = os.pipe()
    os.set_blocking(w, False)
    signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    signal.signal(signal.SIGINT, _handler)
    signal.signal(signal.SIGTERM, _handler)
    sys.unraisablehook = _unraisable(sys.unraisablehook)
    threading.Thread(target=_watch, args=(r,), name="shbake-signals", daemon=True).start()
    os.register_at_fork(after_in_child=_child_after_fork)
    _installed = True
    return True
