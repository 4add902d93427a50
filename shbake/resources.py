"""Bounded resources: special files refused before opening, bounded reads and hashes, the
memory budget every allocation that scales with parameters or image size is checked against,
and the paths the library's entry points take (``str`` or :class:`os.PathLike`,
:func:`path_arguments`).

The budget is ``--max-memory`` (``shbake --max-memory 4G …``), else the environment variable
``SHBAKE_MAX_MEMORY``, else 80 % of the memory the kernel reports available
(``MemAvailable`` in ``/proc/meminfo``; 8 GiB where that cannot be read). An estimate above
it is refused with one line naming the estimate, before anything is allocated.
"""

import functools
import inspect
import os
import re
import stat

from shbake.errors import FormatError, ImageReadError, ParameterError, ResourceError

DEFAULT_BUDGET_FRACTION = 0.8
"""Share of the available memory a run may plan to use by default."""
FALLBACK_BUDGET = 8 << 30
"""Budget where the available memory cannot be read (bytes)."""

_budget_override: int | None = None
_inputs: dict[str, tuple | None] = {}
"""Every input of the run (absolute path, first-read order) → its file's identity
(``st_dev, st_ino``) when it was read, ``None`` if it did not exist."""
_outputs: dict[str, tuple | None] = {}
"""Every declared output → its file's identity when declared (``None``: not there yet)."""
_by_identity: dict[tuple, tuple[str, str]] = {}
"""A file's identity → ``("input"|"output", path)`` first seen with it: one look-up per
path instead of a comparison with every path of the other side (a scene of 1000 maps
declares 4000 outputs: 16 million ``stat`` calls)."""
_tracking = False
_reading_back = False

_UNITS = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


def parse_size(text: str) -> int:
    """``"4G"``, ``"512M"``, ``"1.5g"``, ``"1000000"`` → bytes (binary units)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([kKmMgGtT]?)(i?[bB])?\s*", str(text))
    if not m:
        raise ParameterError(f"--max-memory {text!r}: expected a size such as 4G or 512M")
    value = int(float(m.group(1)) * _UNITS[m.group(2).lower()])
    if value <= 0:
        raise ParameterError(f"--max-memory {text!r}: must be positive")
    return value


def set_memory_budget(nbytes: int | None) -> None:
    """Set (or with ``None`` reset) the budget for this process."""
    global _budget_override
    _budget_override = nbytes


def available_memory() -> int | None:
    """``MemAvailable`` from ``/proc/meminfo`` in bytes, or ``None``."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def memory_budget() -> int:
    """The memory budget in bytes (see the module docstring)."""
    if _budget_override is not None:
        return _budget_override
    env = os.environ.get("SHBAKE_MAX_MEMORY")
    if env:
        return parse_size(env)
    avail = available_memory()
    return int(avail * DEFAULT_BUDGET_FRACTION) if avail else FALLBACK_BUDGET


def human(nbytes: float) -> str:
    """``1.5 GiB``-style text."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(nbytes) < 1024 or unit == "TiB":
            return f"{nbytes:.0f} {unit}" if unit == "B" else f"{nbytes:.1f} {unit}"
        nbytes /= 1024
    return f"{nbytes:.1f} TiB"


def check_memory(nbytes: float, what: str) -> None:
    """Refuse a plan whose memory estimate ``nbytes`` exceeds the budget."""
    budget = memory_budget()
    if nbytes > budget:
        raise ResourceError(
            f"{what} needs an estimated {human(nbytes)}, above the memory budget of "
            f"{human(budget)} (set --max-memory to change it)"
        )


def note_input(path: str) -> None:
    """Record that this process reads ``path``: no output may then replace it
    (:func:`shbake.format.atomic.check_not_input`). Refuses at once an input that is a
    declared output (:func:`declare_output`), before any work is done on it — unless
    :func:`outputs_declared` said the run now reads back what it writes."""
    if not _tracking:
        return
    p = os.path.abspath(os.fspath(path))
    if _reading_back and p in _outputs:
        return
    ident = _identity(p)
    seen = _by_identity.get(ident) if ident is not None else None
    if seen is not None and seen[0] == "output":
        _refuse_same(seen[1], path)
    if p not in _inputs:
        _inputs[p] = ident
        if ident is not None:
            _by_identity.setdefault(ident, ("input", p))


def declare_output(path: str) -> None:
    """Record an output path checked before the run (inputs read later are compared)."""
    if not _tracking:
        return
    p = os.path.abspath(os.fspath(path))
    ident = _identity(p)
    seen = _by_identity.get(ident) if ident is not None else None
    if seen is not None and seen[0] == "input":
        _refuse_same(path, seen[1])
    if p not in _outputs:
        _outputs[p] = ident
        if ident is not None:
            _by_identity.setdefault(ident, ("output", p))


def _refuse_same(shown_output, shown_source) -> None:
    """Refuse, in one line, an output that is the same file as an input."""
    from shbake.errors import OutputError

    raise OutputError(
        f"{shown_output}: is the input {shown_source}; writing it would destroy the input "
        "(choose another output)"
    )


def _identity(path: str) -> tuple | None:
    """``(st_dev, st_ino)`` of the file at ``path`` (links followed), ``None`` if none."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return st.st_dev, st.st_ino


def outputs_declared() -> None:
    """Every output of the run is now declared and checked against every input (a scene
    bake: the lock, each asset and stamp, after the scene, its maps and MERL files were
    read): reading a declared output from here on is reading back what the run wrote
    (measured errors, exports of its ``env_sh`` assets), not a new input."""
    global _reading_back
    _reading_back = True


def same_input(path) -> str | None:
    """The input this process read that ``path`` is (the same file through links or another
    spelling: one look-up by identity), or ``None``."""
    ident = _identity(os.path.abspath(os.fspath(path)))
    seen = _by_identity.get(ident) if ident is not None else None
    return seen[1] if seen is not None and seen[0] == "input" else None


def end_run() -> None:
    """End a command run: stop tracking inputs and outputs."""
    global _tracking, _reading_back
    _tracking = _reading_back = False
    _inputs.clear()
    _outputs.clear()
    _by_identity.clear()


def start_run() -> None:
    """Start a command run: forget earlier inputs and outputs, and track them from now on
    (library calls outside a run are not tracked: a program may write then read a file)."""
    global _tracking, _reading_back
    _inputs.clear()
    _outputs.clear()
    _by_identity.clear()
    _tracking, _reading_back = True, False


def _path_text(value):
    """``value`` with every path in it as ``str``: a ``str`` or :class:`os.PathLike` through
    :func:`os.fspath`, a list or tuple item by item (a map list's ``(map, output)`` pairs);
    anything else (``None``) as it is."""
    if type(value) in (list, tuple):
        return type(value)(_path_text(v) for v in value)
    return os.fspath(value) if isinstance(value, (str, os.PathLike)) else value


def path_arguments(*names: str):
    """Decorator of a library entry point: its arguments ``names`` take a ``str`` or an
    :class:`os.PathLike` (``pathlib.Path``), also in a list or tuple, and reach the function
    as ``str`` — converted once, here, for every reader below it (OpenImageIO takes ``str``
    alone) and every path it records or prints. A name the function does not take is a
    ``TypeError`` at import."""

    def decorate(fn):
        signature = inspect.signature(fn)
        unknown = set(names) - set(signature.parameters)
        if unknown:
            raise TypeError(f"{fn.__qualname__} takes no argument {', '.join(sorted(unknown))}")

        @functools.wraps(fn)
        def call(*args, **kwargs):
            bound = signature.bind(*args, **kwargs)
            for name in names:
                if name in bound.arguments:
                    bound.arguments[name] = _path_text(bound.arguments[name])
            return fn(*bound.args, **bound.kwargs)

        return call

    return decorate


def check_regular_file(path: str, what: str = "input", own_output: bool = False) -> os.stat_result:
    """``os.stat`` of ``path`` after refusing folders, FIFOs, sockets and devices.

    Called before a file is opened, so that reading it cannot block (FIFO) or run
    forever (``/dev/zero``). Records ``path`` as an input (:func:`note_input`) unless
    ``own_output`` (an output of this run read back).
    """
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise ImageReadError(f"{path}: no such file ({what})") from None
    except OSError as e:
        raise ImageReadError(f"{path}: cannot read ({what}: {e.strerror})") from None
    mode = st.st_mode
    if stat.S_ISDIR(mode):
        raise ImageReadError(f"{path}: is a directory, not a file ({what})")
    if not stat.S_ISREG(mode):
        kind = (
            "a FIFO" if stat.S_ISFIFO(mode)
            else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
            else "a socket" if stat.S_ISSOCK(mode)
            else "not a regular file"
        )  # fmt: skip
        raise ResourceError(f"{path}: is {kind}, not a regular file ({what})")
    if not own_output:
        note_input(path)
    return st


def read_bounded(path: str, limit: int, what: str = "input") -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes (read at most ``limit + 1``)."""
    check_regular_file(path, what)
    with open(path, "rb") as f:
        data = f.read(limit + 1)
    if len(data) > limit:
        raise ResourceError(f"{path}: larger than the {human(limit)} a {what} can be")
    return data


def file_identity(path: str) -> tuple | None:
    """``(inode, size, mtime ns)`` of ``path``, or ``None`` when it cannot be stat'ed: equal
    before and after a read when no one wrote the file in between."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_ino, st.st_size, st.st_mtime_ns)


def check_digest(path: str, got: str, want: str, what: str) -> None:
    """Refuse ``path``, the ``what`` (``map``, ``MERL file``) an asset was baked from, when
    the SHA-256 of the bytes read from it, ``got``, is not ``want``, the one the asset
    records: a file of the same name but other bytes gives a silently wrong result. The
    digest found is not shown: a recorded path may name a file the user did not name."""
    if got != want:
        raise FormatError(
            f"{path}: its SHA-256 differs from the one recorded in the asset "
            f"({str(want)[:12]}…); not the {what} this asset was baked from"
        )


def sha256_of(path: str, own_output: bool = False) -> str:
    """Hex SHA-256 of a regular file's bytes, reading no more than its size at open time
    (``own_output``: see :func:`check_regular_file`)."""
    import hashlib  # 2 ms of OpenSSL set-up that a plain bake (no hash) never pays

    st = check_regular_file(path, "hashed file", own_output)
    h = hashlib.sha256()
    left = st.st_size
    with open(path, "rb") as f:
        while left > 0:
            chunk = f.read(min(1 << 20, left))
            if not chunk:
                break
            h.update(chunk)
            left -= len(chunk)
    return h.hexdigest()
