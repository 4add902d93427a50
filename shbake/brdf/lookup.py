"""Bilinear look-up of a parabolic-map table at a view direction (what a GPU sampler does)."""

import numba
import numpy as np

from shbake.jit import jit, pjit


@jit
def fetch_into(table, vx, vy, vz, out):
    """``out (n, 3) = c(v)`` by bilinear filtering of ``table (H, W, n, 3)``, edges clamped.

    Check-free kernel: ``v`` unit; views below the horizon read the rim.
    """
    h, w = table.shape[0], table.shape[1]
    z = vz if vz > 0.0 else 0.0
    x = (vx / (1.0 + z) + 1.0) * 0.5 * w - 0.5
    y = (vy / (1.0 + z) + 1.0) * 0.5 * h - 0.5
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    x0 = min(int(x), w - 2) if w > 1 else 0
    y0 = min(int(y), h - 2) if h > 1 else 0
    fx, fy = x - x0, y - y0
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    for i in range(table.shape[2]):
        for c in range(table.shape[3]):
            out[i, c] = (1.0 - fy) * (
                (1.0 - fx) * table[y0, x0, i, c] + fx * table[y0, x1, i, c]
            ) + fy * ((1.0 - fx) * table[y1, x0, i, c] + fx * table[y1, x1, i, c])


@pjit
def _fetch_many(table, views, out):
    for k in numba.prange(views.shape[0]):
        fetch_into(table, views[k, 0], views[k, 1], views[k, 2], out[k])


def lookup(table: np.ndarray, views) -> np.ndarray:
    """Bilinear ``c(v)`` for unit local view directions ``(..., 3)`` → ``(..., n, 3)``."""
    v = np.asarray(views, dtype=float)
    flat = np.ascontiguousarray(v.reshape(-1, 3))
    t = np.ascontiguousarray(table, dtype=np.float64)
    out = np.empty((flat.shape[0],) + t.shape[2:])
    _fetch_many(t, flat, out)
    return out.reshape(v.shape[:-1] + t.shape[2:])
