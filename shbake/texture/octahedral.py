"""Octahedral maps of the sphere (Cigolle et al. 2014), about +Y (the up axis).

For unit ``d``: ``p = (d_x, d_z)/(|d_x|+|d_y|+|d_z|)``, folded for ``d_y < 0`` as
``p ← ((1−|p_z|) sign p_x, (1−|p_x|) sign p_z)``; texture ``(u, w) = (p+1)/2``
(``u`` along columns, ``w`` along rows), texel centres at ``(k+½)/size``,
bilinear fetch clamped at the edges.
"""

import numpy as np

from shbake.jit import jit
from shbake.texture.bilinear import axis, blend


@jit
def decode(u, w):
    """Unit direction of octahedral texture coordinates ``(u, w) ∈ [0, 1]²``."""
    px, pz = 2.0 * u - 1.0, 2.0 * w - 1.0
    dy = 1.0 - abs(px) - abs(pz)
    dx, dz = px, pz
    if dy < 0.0:
        dx = (1.0 - abs(pz)) * (1.0 if px >= 0.0 else -1.0)
        dz = (1.0 - abs(px)) * (1.0 if pz >= 0.0 else -1.0)
    n = np.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / n, dy / n, dz / n


@jit
def encode(dx, dy, dz):
    """Octahedral texture coordinates ``(u, w)`` of a unit direction."""
    s = abs(dx) + abs(dy) + abs(dz)
    px, pz = dx / s, dz / s
    if dy < 0.0:
        px, pz = (
            (1.0 - abs(pz)) * (1.0 if px >= 0.0 else -1.0),
            (1.0 - abs(px)) * (1.0 if pz >= 0.0 else -1.0),
        )
    return 0.5 * (px + 1.0), 0.5 * (pz + 1.0)


@jit
def fetch(level, dx, dy, dz, out):
    """``out[c]`` = every channel of a square octahedral map ``level (size, size, C)`` at
    unit ``d`` (one address computation for all channels)."""
    size = level.shape[0]
    u, w = encode(dx, dy, dz)
    i0, i1, fy = axis(w * size - 0.5, size)
    j0, j1, fx = axis(u * size - 0.5, size)
    for c in range(out.shape[0]):
        out[c] = blend(level[i0, j0, c], level[i0, j1, c], level[i1, j0, c], level[i1, j1, c],
                       fy, fx)  # fmt: skip
