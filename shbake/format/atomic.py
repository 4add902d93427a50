"""Atomic file output: write to a temporary file in the target directory, then ``os.replace``.

No partial or corrupt output is ever left at the target path: on any error
the temporary file is removed and the previous content (if any) survives.
"""

import os
from contextlib import contextmanager

from shbake.errors import OutputError


def check_writable_dir(path: str) -> str:
    """Return the directory of ``path`` after checking it exists and is writable."""
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise OutputError(f"{path}: directory {directory} does not exist")
    if not os.access(directory, os.W_OK):
        raise OutputError(f"{path}: directory {directory} is not writable")
    if os.path.isdir(path):
        raise OutputError(f"{path}: is a directory")
    return directory


def _reserve(directory: str, prefix: str, suffix: str) -> str:
    """Create a new empty file ``prefix + random + suffix`` (mode 0600) and return its path.

    What ``tempfile.mkstemp`` does, without importing tempfile (and with it
    shutil, random, bz2, lzma: ~20 ms of every command's start-up).
    """
    for _ in range(100):
        tmp = os.path.join(directory, f"{prefix}{os.urandom(6).hex()}{suffix}")
        try:
            fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise OutputError(f"{directory}: cannot create a temporary file")


@contextmanager
def atomic_path(path: str):
    """Yield a temporary path beside ``path`` (same suffix); move it into place on success."""
    directory = check_writable_dir(path)
    base = os.path.basename(path)
    suffix = os.path.splitext(base)[1]
    tmp = _reserve(directory, f".{base}.", f".tmp{suffix}")
    try:
        yield tmp
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_text(path: str, text: str) -> None:
    """Write a text file atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
