"""The DFG table: directional albedos of the Fresnel-free GGX BRDF, shared by both probes.

``A0(μ, r) = ∫ f_DV (n·l) dl`` and ``A1(μ, r) = ∫ f_DV (1 − v·h)^5 (n·l) dl``
for ``μ = n·v`` and GGX width ``α`` (Silvennoinen et al. 2025,
eq. 6–8 under unit light), integrated by :func:`shbake.reference.ggx.ggx_integrals`
in a white environment. Split-sum's second factor is ``F0 A0 + (1 − F0) A1``
(Karis 2013). The SH-exp Fresnel tail is ``E1 ≈ E0(ρ, ρ) · A1(μ)/A0(1)``
(:mod:`shbake.shading.shexp`; eq. 15's ``E0 · A1/A0`` before 2026-11-28): exact under
constant light; the paper's literal ``E0 · A1`` loses the ``1/A0`` factor (``> 1`` at
grazing views). Read by :mod:`shbake.shading.dfg`.

The table's second axis is node-centred in ``√α`` (perceptual roughness
``r``, ``α = r²``) so that narrow lobes get as many nodes as wide ones; look-ups
take ``α``.
"""

import numpy as np

from shbake.conventions import DFG_MU_MIN, DFG_SAMPLES, DFG_SIZE, ROUGHNESS_MIN
from shbake.reference.ggx import ggx_integrals


def dfg_axes(size: int = DFG_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """Node-centred axes: ``μ`` in ``[1e-3, 1]`` and ``√α`` in ``[0.02, 1]``, ``size`` each."""
    return np.linspace(DFG_MU_MIN, 1.0, size), np.linspace(ROUGHNESS_MIN, 1.0, size)


def dfg_table(size: int = DFG_SIZE, samples: int = DFG_SAMPLES) -> np.ndarray:
    """``(size_μ, size_r, 2)`` table of ``(A0, A1)``; axes from :func:`dfg_axes`."""
    mu, r = dfg_axes(size)
    m, rr = np.meshgrid(mu, r, indexing="ij")
    views = np.stack([np.sqrt(1.0 - m**2), np.zeros_like(m), m], -1).reshape(-1, 3)
    normals = np.tile([0.0, 0.0, 1.0], (views.shape[0], 1))
    white = np.ones((4, 8, 3), dtype=np.float32)
    e0, e1 = ggx_integrals(white, views, normals, rr.reshape(-1) ** 2, samples)
    return np.stack([e0[:, 0], e1[:, 0]], -1).reshape(size, size, 2)
