"""Lambertian BRDF ``f = ρ/π`` (Lambert 1760)."""

import numpy as np

from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SPEC = ModelSpec(
    name="lambert",
    model_id=0,
    params=(Param("rho", 0.8, 0.0, 1.0, colour=True, doc="albedo, 0…1"),),
    citation="J. H. Lambert, Photometria (1760)",
    summary="ideal diffuse, f = rho/pi",
    has_lobe=False,
)


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """``out[c] = ρ_c/π`` (1/sr); ``prm = (ρ_r, ρ_g, ρ_b)``."""
    for c in range(3):
        out[c] = prm[c] / np.pi
