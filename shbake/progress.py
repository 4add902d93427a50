"""Progress reporting for long work, without any drawing in the library.

Library functions that can take more than a couple of seconds accept a
:class:`Progress` and wrap each step in :meth:`Progress.task`::

    with progress.task("brute force", total=len(chunks)) as advance:
        for chunk in chunks:
            ...
            advance(1)

The base class does nothing; the CLI passes a subclass that draws bars on
stderr (``shbake_cli.options.BarProgress``).
"""

from contextlib import contextmanager


class Progress:
    """A sink for progress; this base class ignores everything."""

    def _open(self, description: str, total: float | None, unit: str):
        return None

    def _advance(self, handle, n: float) -> None:
        pass

    def _close(self, handle) -> None:
        pass

    @contextmanager
    def task(self, description: str, total: float | None = None, unit: str = "it"):
        """A step of ``total`` units; yields ``advance(n=1)``."""
        handle = self._open(description, total, unit)

        def advance(n: float = 1) -> None:
            if handle is not None:
                self._advance(handle, n)

        try:
            yield advance
        finally:
            if handle is not None:
                self._close(handle)


NO_PROGRESS = Progress()
"""The silent default."""
