"""Exceptions raised by shbake.

Every error a user can cause is a :class:`ShbakeError`; the CLI turns it into a
one-line message on stderr and a non-zero exit status. The subclasses also
derive from the matching built-in so library callers can catch either.
"""


class ShbakeError(Exception):
    """Base class of every error shbake raises on purpose."""


class InputError(ShbakeError, ValueError):
    """An input (image, asset, parameter) is invalid."""


class ImageReadError(InputError, OSError):
    """An image file is missing, unreadable, truncated or not an image."""


class LayoutError(InputError):
    """The layout of an environment image is unknown or inconsistent."""


class ParameterError(InputError):
    """A numeric or named parameter is outside what shbake accepts."""


class FormatError(InputError):
    """An asset file is not a shbake asset, or of an unknown kind or version."""


class OutputError(ShbakeError, OSError):
    """An output could not be written (unwritable path, value overflow)."""


class ResourceError(InputError):
    """A run would need more memory than the budget (``--max-memory``), or an input is a
    special file (FIFO, device) that cannot be read with bounded time and memory."""
