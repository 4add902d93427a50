"""The one numba decorator every kernel uses.

Kernels are check-free: they assume the caller (a public Python function)
validated shapes, dtypes and ranges, and say so in their docstrings.
``cache=True`` keeps compiled machine code in ``__pycache__`` so a second
process (a ``make -j`` pipeline, a test worker) does not compile again.
"""

from functools import partial

import numba

jit = partial(numba.njit, cache=True, fastmath=False, nogil=True)
"""``numba.njit`` with ``cache=True``; serial kernels."""

pjit = partial(numba.njit, cache=True, fastmath=False, nogil=True, parallel=True)
"""``numba.njit`` with ``cache=True`` and ``parallel=True``; kernels with ``prange``."""
