"""The parabolic map of the view hemisphere (Heidrich & Seidel 1999; SPEC §4).

For ``v = (x, y, z)``, ``z ≥ 0``: ``p = (x, y)/(1 + z)`` in the unit disc;
texture coordinates ``u = (p_x + 1)/2`` (columns, left to right) and
``w = (p_y + 1)/2`` (rows, row 0 at ``p_y = −1``); texel ``(i, j)`` of an
``H × W`` map has its centre at ``((j+½)/W, (i+½)/H)``. Texels whose centre
lies outside the disc hold the value of the horizon direction ``(p/|p|, 0)``,
so bilinear filtering at the rim blends only valid values.
"""

import numpy as np

from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.texture.bilinear import axis, blend

VIEW_Z_MIN = 1e-4
"""Views closer to the horizon are evaluated at ``z = VIEW_Z_MIN`` (finite tables)."""
RESOLUTION_LIMIT = 4096


def check_resolution(height: int, width: int) -> tuple[int, int]:
    """Parabolic maps are 2…4096 texels a side."""
    for name, n in (("height", height), ("width", width)):
        if not isinstance(n, int | np.integer) or not 2 <= n <= RESOLUTION_LIMIT:
            raise ParameterError(
                f"parabolic map {name} must be an integer in [2, {RESOLUTION_LIMIT}], got {n}"
            )
    return int(height), int(width)


def texel_views(height: int, width: int) -> np.ndarray:
    """Unit view direction of every texel, ``(H, W, 3)``, ``z ≥ VIEW_Z_MIN``."""
    check_resolution(height, width)
    px = 2.0 * (np.arange(width) + 0.5) / width - 1.0
    py = 2.0 * (np.arange(height) + 0.5) / height - 1.0
    px, py = np.meshgrid(px, py)
    r2 = px * px + py * py
    inside = r2 <= 1.0
    scale = np.where(inside, 1.0, 1.0 / np.sqrt(np.maximum(r2, 1e-300)))
    px, py = px * scale, py * scale
    r2 = np.minimum(r2, 1.0)
    v = np.stack([2.0 * px, 2.0 * py, 1.0 - r2], axis=-1) / (1.0 + r2)[..., None]
    v[..., 2] = np.maximum(v[..., 2], VIEW_Z_MIN)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@jit
def taps(h, w, vx, vy, vz):
    """Bilinear taps of unit view ``v`` in an ``h × w`` map: ``(y0, y1, fy, x0, x1, fx)``.

    Check-free kernel; views below the horizon read the rim.
    """
    z = vz if vz > 0.0 else 0.0
    y0, y1, fy = axis((vy / (1.0 + z) + 1.0) * 0.5 * h - 0.5, h)
    x0, x1, fx = axis((vx / (1.0 + z) + 1.0) * 0.5 * w - 0.5, w)
    return y0, y1, fy, x0, x1, fx


@jit
def fetch_flat_into(table, vx, vy, vz, out):
    """``out (M,) = c(v)`` for a C-contiguous ``table (H, W, M)``: :func:`fetch_into` on the
    texels' values flattened (one loop over them, which vectorises). Check-free kernel."""
    y0, y1, fy, x0, x1, fx = taps(table.shape[0], table.shape[1], vx, vy, vz)
    t00 = table[y0, x0]
    t01 = table[y0, x1]
    t10 = table[y1, x0]
    t11 = table[y1, x1]
    for e in range(out.shape[0]):
        out[e] = blend(t00[e], t01[e], t10[e], t11[e], fy, fx)


@jit
def fetch_into(table, vx, vy, vz, out):
    """``out (n, C) = c(v)`` by bilinear filtering of ``table (H, W, n, C)``, edges clamped.

    Check-free kernel: ``v`` unit; views below the horizon read the rim.
    """
    y0, y1, fy, x0, x1, fx = taps(table.shape[0], table.shape[1], vx, vy, vz)
    for i in range(table.shape[2]):
        for c in range(table.shape[3]):
            out[i, c] = blend(
                table[y0, x0, i, c], table[y0, x1, i, c], table[y1, x0, i, c],
                table[y1, x1, i, c], fy, fx,
            )  # fmt: skip


@jit
def _fetch_many(table, views, out, b0, b1):
    for k in range(b0, b1):
        fetch_into(table, views[k, 0], views[k, 1], views[k, 2], out[k])


def fetch(table: np.ndarray, views) -> np.ndarray:
    """Bilinear ``c(v)`` of an ``(H, W, n, C)`` table at unit local views ``(..., 3)``.

    Returns ``(..., n, C)``.
    """
    v = np.asarray(views, dtype=float)
    flat = np.ascontiguousarray(v.reshape(-1, 3))
    t = np.ascontiguousarray(table, dtype=np.float64)
    out = np.empty((flat.shape[0],) + t.shape[2:])
    run_blocks(_fetch_many, flat.shape[0], out.size * 8.0, t, flat, out)
    return out.reshape(v.shape[:-1] + t.shape[2:])
