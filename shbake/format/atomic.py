"""Atomic file output: write to a temporary file in the target directory, then ``os.replace``.

No partial or corrupt output is ever left at the target path: on any error
the temporary file is removed and the previous content (if any) survives.
"""

import os
import tempfile
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


@contextmanager
def atomic_path(path: str):
    """Yield a temporary path beside ``path`` (same suffix); move it into place on success."""
    directory = check_writable_dir(path)
    base = os.path.basename(path)
    suffix = os.path.splitext(base)[1]
    fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=f".tmp{suffix}", dir=directory)
    os.close(fd)
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
