"""Dask schedulers: an address checked, connected before any planning; workers write nothing.

``--scheduler`` takes ``[SCHEME://]HOST:PORT`` with ``SCHEME`` one of
:data:`SCHEMES` (``tcp`` when omitted), ``HOST`` a host name, an IPv4 address
or a bracketed IPv6 address, ``PORT`` in 1-65535: anything else (other schemes,
spaces, shell or control characters) is refused by :func:`parse_address`
before any connection (a usage error in the CLI). :func:`session` connects
before the caller plans anything and gives up after its ``timeout`` seconds
(:data:`CONNECT_SECONDS` unless given: ``--connect-timeout`` in the CLI, a finite
number in (0, :data:`CONNECT_SECONDS_LIMIT`], else a
:class:`~shbake.errors.ParameterError` from :func:`check_timeout`) with one line
naming the timeout used (:class:`~shbake.errors.InputError`); the connection is tried
first with a bare Dask comm, so a failure leaves no half-made ``Client``
behind (whose finaliser would block and print).

Workers write nothing where outputs go. A task runs inside
:func:`shbake.format.atomic.collected` and returns its outputs' bytes; the
client writes them in its own transaction (:func:`write_returned`). So when
the client stops (an error, SIGINT, SIGTERM), :func:`completed` cancels every
future, the client's transaction removes what it staged, and a task still
running on a worker finishes into its own scratch folder and is discarded:
no file can appear after the client has gone.

Dask's own logging (``distributed``, ``tornado``, ``asyncio``) is silenced in
the client: a run's messages are shbake's one-line messages.
"""

import logging
import math
import os
import re
from contextlib import contextmanager, suppress

from shbake.errors import InputError, OutputError, ParameterError

SCHEMES = ("tcp", "tls", "ws", "wss")
"""Dask comm schemes a scheduler address may name (``inproc`` is in-process only; ``ucx``
needs a library shbake does not install)."""
_LABEL = r"[A-Za-z0-9](?:[A-Za-z0-9_-]{0,61}[A-Za-z0-9])?"
ADDRESS = re.compile(
    rf"(?:({'|'.join(SCHEMES)})://)?({_LABEL}(?:\.{_LABEL})*|\[[0-9A-Fa-f:.]+\]):([0-9]{{1,5}})"
)
"""``[SCHEME://]HOST:PORT`` (ASCII only: no space, shell or control character)."""
ADDRESS_MAX_CHARS = 300
"""Longest address accepted (a host name is at most 253 characters)."""
CONNECT_SECONDS = 10.0
"""How long connecting to a scheduler may take before the run is refused, by default."""
CONNECT_SECONDS_LIMIT = 600.0
"""The longest connect timeout accepted (``--connect-timeout``)."""
CLOSE_SECONDS = 2.0
"""How long closing the client may take (its futures are cancelled first on an error)."""
QUIET_LOGGERS = ("distributed", "tornado", "asyncio", "bokeh")
"""Loggers of Dask and its event loop, silenced in the client."""


def parse_address(text: str) -> str:
    """The scheduler address ``text`` with its scheme (``tcp://`` when omitted); a
    :class:`~shbake.errors.ParameterError` for anything else (module docstring)."""
    text = str(text)
    m = ADDRESS.fullmatch(text) if len(text) <= ADDRESS_MAX_CHARS else None
    if m is None or not 1 <= int(m.group(3)) <= 65535:
        shown = text if len(text) <= 80 else text[:79] + "…"
        raise ParameterError(
            f"{shown!r} is not a Dask scheduler address (expected [SCHEME://]HOST:PORT, "
            f"SCHEME one of {', '.join(SCHEMES)})"
        )
    return text if m.group(1) else f"tcp://{text}"


def check_timeout(timeout) -> float:
    """``timeout`` as a float if it is a finite number of seconds in
    (0, :data:`CONNECT_SECONDS_LIMIT`]; a :class:`~shbake.errors.ParameterError` otherwise."""
    try:
        seconds = float(timeout)
    except (TypeError, ValueError):
        seconds = math.nan
    if not (math.isfinite(seconds) and 0 < seconds <= CONNECT_SECONDS_LIMIT):
        raise ParameterError(f"connect timeout {timeout!r}: expected seconds in "
                             f"(0, {CONNECT_SECONDS_LIMIT:g}]")  # fmt: skip
    return seconds


def quiet_logging() -> None:
    """Send the records of :data:`QUIET_LOGGERS` (and their children) nowhere."""
    for name in list(logging.root.manager.loggerDict) + list(QUIET_LOGGERS):
        if name.split(".")[0] not in QUIET_LOGGERS:
            continue
        logger = logging.getLogger(name)
        top = name in QUIET_LOGGERS
        logger.handlers[:] = [logging.NullHandler()] if top else []
        logger.propagate = not top


def _reason(e: BaseException) -> str:
    """Why a connection failed: the first system error in the chain of causes (Dask wraps
    them in its own timeout), else the error's first line."""
    cause = e
    while cause is not None:
        if isinstance(cause, OSError) and cause.strerror:
            return cause.strerror
        cause = cause.__cause__ or cause.__context__
    if isinstance(e, OSError) and str(e).startswith("Timed out"):
        return "no answer"
    lines = str(e).strip().splitlines()
    return lines[0][:200] if lines else type(e).__name__


def _reach(address: str, timeout: float = CONNECT_SECONDS) -> None:
    """Open and close one Dask comm to ``address`` (the handshake included), within
    ``timeout`` seconds; raises what Dask raises."""
    import asyncio

    from distributed.comm import connect
    from distributed.security import Security

    async def probe():
        args = Security().get_connection_args("client")
        comm = await connect(address, timeout=timeout, **args)
        await comm.close()

    asyncio.run(probe())


def connect(address: str, timeout: float = CONNECT_SECONDS):
    """A ``distributed.Client`` of the scheduler at ``address`` (checked by
    :func:`parse_address`); one line if it does not answer within ``timeout`` seconds
    (checked by :func:`check_timeout`)."""
    address = parse_address(address)
    timeout = check_timeout(timeout)
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - dask is an install requirement
        raise ParameterError("--scheduler needs the 'distributed' package") from None
    quiet_logging()
    try:
        _reach(address, timeout)
        return Client(address, timeout=timeout, set_as_default=False)
    except Exception as e:  # noqa: BLE001 - whatever Dask raises is "cannot reach"
        raise InputError(f"cannot reach the Dask scheduler at {address} within "
                         f"{timeout:g} s ({_reason(e)})") from None  # fmt: skip


def _close(client) -> None:
    with suppress(Exception):
        client.close(timeout=CLOSE_SECONDS)


@contextmanager
def session(scheduler, timeout: float = CONNECT_SECONDS):
    """A connected client for ``scheduler``: an address (connected here within ``timeout``
    seconds, before the block, and closed after it) or a ``distributed.Client`` (used as it
    is; ``timeout`` is then not used)."""
    if not isinstance(scheduler, str):
        yield scheduler
        return
    client = connect(scheduler, timeout)
    try:
        yield client
    finally:
        _close(client)


def completed(client, futures):
    """``(index, result)`` of each future as it completes; on any error or interrupt (here or
    in the caller's loop) every future is cancelled before the exception goes on."""
    from distributed import as_completed

    index = {f.key: i for i, f in enumerate(futures)}
    try:
        for future in as_completed(futures, loop=client.loop):
            result = future.result()
            future.release()
            yield index[future.key], result
    except BaseException:
        with suppress(Exception):
            client.cancel(futures)
        raise


def write_returned(path: str, data: bytes) -> None:
    """Write the bytes a worker returned for ``path``, in this process's transaction."""
    from shbake.format.atomic import atomic_path, makedirs

    makedirs(os.path.dirname(os.path.abspath(path)))
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(data)


def inside(folder: str, relative: str) -> str:
    """``folder/relative``, refused if it leaves ``folder`` (a returned file's name)."""
    folder = os.path.abspath(folder)
    path = os.path.normpath(os.path.join(folder, relative))
    if os.path.isabs(relative) or os.path.commonpath([folder, path]) != folder:
        raise OutputError(f"{relative!r}: a worker returned a file outside {folder}")
    return path
