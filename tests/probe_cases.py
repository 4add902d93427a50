"""What the probe tests share (reference, bakers, shading, format, batch and cli folders): a
small SH-exp fit configuration and random view/normal pairs above the surface."""

import numpy as np

from shbake.bakers.shexp import FitConfig

SMALL = FitConfig(normals=16, views=16, samples=256)
"""A fit small enough for a test: 16 normals × 16 views, 256 samples per target."""


def random_pairs(n, seed):
    """Up to ``n`` unit (view, normal) pairs with ``v·n > 0.05`` (views below flipped)."""
    rng = np.random.default_rng(seed)
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v = np.where(np.einsum("ij,ij->i", v, nrm)[:, None] < 0.05, -v, v)
    keep = np.einsum("ij,ij->i", v, nrm) > 0.05
    return v[keep], nrm[keep]
