"""The preview's geometry: a unit sphere seen orthographically from +Z, +Y up."""

import numpy as np


def sphere_geometry(size: int):
    """Normals ``(size, size, 3)``, longitude-line tangents and the coverage mask.

    Pixel ``(i, j)`` has centre ``x = 2(j+½)/size − 1``, ``y = 1 − 2(i+½)/size``;
    inside the disc the normal is ``(x, y, sqrt(1 − x² − y²))``. Tangents
    follow longitude lines about +Y (Mehta et al. 2012, Fig. 1): the unit
    projection of +Y on the tangent plane (+X where that vanishes).
    """
    c = 2.0 * (np.arange(size) + 0.5) / size - 1.0
    x, y = np.meshgrid(c, -c)
    r2 = x * x + y * y
    mask = r2 < 1.0
    z = np.sqrt(np.maximum(0.0, 1.0 - r2))
    n = np.stack([x, y, z], axis=-1)
    n[~mask] = (0.0, 0.0, 1.0)
    up = np.array([0.0, 1.0, 0.0])
    t = up - (n @ up)[..., None] * n
    norm = np.linalg.norm(t, axis=-1, keepdims=True)
    t = np.where(norm > 1e-12, t / np.maximum(norm, 1e-300), np.array([1.0, 0.0, 0.0]))
    return n, t, mask
