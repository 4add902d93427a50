"""The simplified microfacet BRDF of Ramamoorthi & Hanrahan (2002), eq. 11.

The paper defines the cosine-weighted BRDF ``ρ̂ = f cos θ_i`` directly::

    ρ̂(s, v) = ρ_s exp(−(θ_h/σ)²) / (4π σ²),   θ_h = acos(n̂·h),  h = (s+v)/|s+v|

(a Gaussian in the half-angle, after Torrance & Sparrow 1967), so the
radiometric BRDF is ``f = ρ̂ / s_z`` (1/sr) above the horizon and 0 below it.
``σ`` is an angle in radians; the paper's Table 5 uses ``σ = 0.1 … 0.5``.
Lobe sampling: the Phong lobe about the mirror direction with exponent
``2/σ²`` (a valid density/sampler pair; it only steers importance).
"""

import numpy as np

from shbake.brdf.phong import mirror_lobe_pdf, mirror_lobe_sample
from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SPEC = ModelSpec(
    name="microfacet",
    model_id=8,
    params=(
        Param("rho_s", 1.0, 0.0, 1.0, colour=True, doc="scale of the lobe"),
        Param("sigma", 0.2, 0.02, 1.5, doc="half-angle width σ in radians (RH02 eq. 11)"),
    ),
    citation="R. Ramamoorthi, P. Hanrahan, Frequency space environment map rendering, "
    "SIGGRAPH 2002, eq. 11; K. Torrance, E. Sparrow, JOSA 57(9) 1967",
    summary="simplified microfacet: Gaussian in the half-angle, cosine included",
)


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (ρ_s[3], σ)``."""
    sigma = prm[3]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    lobe = 0.0
    if sz > 0.0 and vz > 0.0 and norm > 0.0:
        th = np.arccos(min(1.0, max(-1.0, hz / norm)))
        lobe = np.exp(-((th / sigma) ** 2)) / (4.0 * np.pi * sigma * sigma) / sz
    for c in range(3):
        out[c] = prm[c] * lobe


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """A direction from the Phong lobe of exponent ``2/σ²`` about the mirror direction."""
    return mirror_lobe_sample(2.0 / (prm[3] * prm[3]), vx, vy, vz, ur, ua)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` (1/sr)."""
    return mirror_lobe_pdf(2.0 / (prm[3] * prm[3]), sx, sy, sz, vx, vy, vz)
