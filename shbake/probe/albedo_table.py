"""Directional albedos of the Fresnel-free GGX BRDF: the DFG table both probes share.

``A0(μ, r) = ∫ f_DV (n·l) dl`` and ``A1(μ, r) = ∫ f_DV (1 − v·h)^5 (n·l) dl``
for ``μ = n·v`` and perceptual roughness ``r`` (Silvennoinen et al. 2025,
eq. 6–8 under unit light). Split-sum's second factor is
``F0 A0 + (1 − F0) A1`` (Karis 2013). The SH-exp Fresnel tail (eq. 15) is
``E1 ≈ E0 · A1/A0``: exact under constant light; the paper's literal
``E0 · A1`` loses the ``1/A0`` factor (``> 1`` at grazing views).
"""

import numpy as np

from shbake.jit import jit
from shbake.probe.ggx_integrals import ROUGHNESS_MIN, ggx_integrals

TABLE_SIZE = 32
TABLE_SAMPLES = 8192
MU_MIN = 1e-3


def table_axes(size: int = TABLE_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """Node-centred axes: ``μ`` in ``[1e-3, 1]`` and ``r`` in ``[0.02, 1]``, ``size`` each."""
    return np.linspace(MU_MIN, 1.0, size), np.linspace(ROUGHNESS_MIN, 1.0, size)


def albedo_table(size: int = TABLE_SIZE, samples: int = TABLE_SAMPLES) -> np.ndarray:
    """``(size_μ, size_r, 2)`` table of ``(A0, A1)``; axes from :func:`table_axes`."""
    mu, r = table_axes(size)
    m, rr = np.meshgrid(mu, r, indexing="ij")
    views = np.stack([np.sqrt(1.0 - m**2), np.zeros_like(m), m], -1).reshape(-1, 3)
    normals = np.tile([0.0, 0.0, 1.0], (views.shape[0], 1))
    white = np.ones((4, 8, 3), dtype=np.float32)
    e0, e1 = ggx_integrals(white, views, normals, rr.reshape(-1), samples)
    return np.stack([e0[:, 0], e1[:, 0]], -1).reshape(size, size, 2)


@jit
def table_lookup(table, mu, r):
    """Bilinear ``(A0, A1)`` at ``(μ, r)``, clamped to the table's axes (check-free)."""
    n_mu, n_r = table.shape[0], table.shape[1]
    x = (min(1.0, max(MU_MIN, mu)) - MU_MIN) / (1.0 - MU_MIN) * (n_mu - 1)
    y = (min(1.0, max(ROUGHNESS_MIN, r)) - ROUGHNESS_MIN) / (1.0 - ROUGHNESS_MIN) * (n_r - 1)
    i = min(int(x), n_mu - 2)
    j = min(int(y), n_r - 2)
    fx, fy = x - i, y - j
    a0 = (1 - fx) * ((1 - fy) * table[i, j, 0] + fy * table[i, j + 1, 0]) + fx * (
        (1 - fy) * table[i + 1, j, 0] + fy * table[i + 1, j + 1, 0]
    )
    a1 = (1 - fx) * ((1 - fy) * table[i, j, 1] + fy * table[i, j + 1, 1]) + fx * (
        (1 - fy) * table[i + 1, j, 1] + fy * table[i + 1, j + 1, 1]
    )
    return a0, a1


@jit
def _lookup_many(table, mu, r, out):
    for k in range(mu.shape[0]):
        out[k, 0], out[k, 1] = table_lookup(table, mu[k], r[k])


def lookup(table, mu, r) -> np.ndarray:
    """``(A0, A1)`` at arrays ``μ``, ``r`` (broadcast), shape ``(…, 2)``."""
    m, rr = np.broadcast_arrays(np.asarray(mu, float), np.asarray(r, float))
    out = np.empty(m.shape + (2,))
    _lookup_many(np.asarray(table, float), m.reshape(-1), rr.reshape(-1), out.reshape(-1, 2))
    return out
