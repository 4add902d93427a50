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

VIEW_Z_MIN = 1e-4
"""Views closer to the horizon are evaluated at ``z = VIEW_Z_MIN`` (finite tables)."""


def check_resolution(height: int, width: int) -> tuple[int, int]:
    """Parabolic maps are 2…4096 texels a side."""
    for name, n in (("height", height), ("width", width)):
        if not isinstance(n, int | np.integer) or not 2 <= n <= 4096:
            raise ParameterError(f"parabolic map {name} must be an integer in [2, 4096], got {n}")
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


def view_to_texture(views) -> tuple[np.ndarray, np.ndarray]:
    """Texture coordinates ``(u, w)`` in ``[0, 1]`` of view directions (z clamped ≥ 0)."""
    v = np.asarray(views, dtype=float)
    z = np.maximum(v[..., 2], 0.0)
    return (v[..., 0] / (1.0 + z) + 1.0) / 2.0, (v[..., 1] / (1.0 + z) + 1.0) / 2.0
