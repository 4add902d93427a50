"""Look-up of the DFG table ``(A0, A1)`` over ``(n·v, α)`` (node-centred, bilinear).

The table (``/dfg`` of every probe asset, baked by :mod:`shbake.bakers.dfg`)
has node-centred axes ``μ = n·v ∈ [DFG_MU_MIN, 1]`` and ``√α ∈ [ROUGHNESS_MIN, 1]``
(α the GGX width); queries take ``α`` and are clamped to the axes.
"""

import numpy as np

from shbake.conventions import DFG_MU_MIN, ROUGHNESS_MIN
from shbake.jit import jit
from shbake.texture.bilinear import axis, blend


@jit
def dfg_at(table, mu, alpha):
    """Bilinear ``(A0, A1)`` at ``(μ, α)``, clamped to the table's axes (check-free)."""
    n_mu, n_r = table.shape[0], table.shape[1]
    r = np.sqrt(max(alpha, 0.0))
    x = (min(1.0, max(DFG_MU_MIN, mu)) - DFG_MU_MIN) / (1.0 - DFG_MU_MIN) * (n_mu - 1)
    y = (min(1.0, max(ROUGHNESS_MIN, r)) - ROUGHNESS_MIN) / (1.0 - ROUGHNESS_MIN) * (n_r - 1)
    i0, i1, fx = axis(x, n_mu)
    j0, j1, fy = axis(y, n_r)
    a0 = blend(table[i0, j0, 0], table[i0, j1, 0], table[i1, j0, 0], table[i1, j1, 0], fx, fy)
    a1 = blend(table[i0, j0, 1], table[i0, j1, 1], table[i1, j0, 1], table[i1, j1, 1], fx, fy)
    return a0, a1


@jit
def _dfg_many(table, mu, r, out):
    for k in range(mu.shape[0]):
        out[k, 0], out[k, 1] = dfg_at(table, mu[k], r[k])


def dfg_lookup(table, mu, alpha) -> np.ndarray:
    """``(A0, A1)`` at arrays ``μ``, GGX width ``α`` (broadcast), shape ``(…, 2)``."""
    m, rr = np.broadcast_arrays(np.asarray(mu, float), np.asarray(alpha, float))
    out = np.empty(m.shape + (2,))
    flat = [np.ascontiguousarray(x).reshape(-1) for x in (m, rr)]  # no read-only stride-0 view
    _dfg_many(np.asarray(table, float), *flat, out.reshape(-1, 2))
    return out
