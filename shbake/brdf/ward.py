"""Ward anisotropic BRDF (Ward 1992, eq. 5) with the sampling of Walter (2005).

``f = ρ_d/π + ρ_s exp(−(h_x²/α_x² + h_y²/α_y²)/h_z²) / (4π α_x α_y sqrt(s_z v_z))``
(1/sr), ``h`` the unnormalised half vector's direction. Ward's model is not
energy-conserving at grazing views (its albedo exceeds ``ρ_s`` there); the
table asset records the measured maximum albedo.
Half-vector density ``exp(−tan²θ_h(cos²φ/α_x² + sin²φ/α_y²))/(π α_x α_y cos³θ_h)``
(B. Walter, Notes on the Ward BRDF, Cornell PCG-05-06).
"""

import numpy as np

from shbake.brdf.sampling import TWO_PI, reflect_about
from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SPEC = ModelSpec(
    name="ward",
    model_id=4,
    params=(
        Param("rho_d", 0.0, 0.0, 1.0, colour=True, doc="diffuse albedo"),
        Param("rho_s", 1.0, 0.0, 1.0, colour=True, doc="specular albedo"),
        Param("alpha_x", 0.2, 1e-3, 1.0, doc="slope std. deviation along the tangent (+X)"),
        Param("alpha_y", 0.2, 1e-3, 1.0, doc="slope std. deviation along the bitangent (+Y)"),
    ),
    citation="G. J. Ward, Measuring and modeling anisotropic reflection, SIGGRAPH 1992; "
    "B. Walter, Notes on the Ward BRDF, Cornell PCG-05-06 (2005)",
    summary="anisotropic Gaussian-slope lobe",
    energy=("rho_d", "rho_s"),
    isotropic=False,
    aliases={"alpha": ("alpha_x", "alpha_y")},
)


@jit
def _gauss(ax, ay, hx, hy, hz):
    return np.exp(-((hx / ax) ** 2 + (hy / ay) ** 2) / (hz * hz))


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (ρ_d[3], ρ_s[3], α_x, α_y)``."""
    ax, ay = prm[6], prm[7]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    spec = 0.0
    if hz > 0.0 and sz > 0.0 and vz > 0.0:
        spec = _gauss(ax, ay, hx, hy, hz) / (4.0 * np.pi * ax * ay * np.sqrt(sz * vz))
    for c in range(3):
        out[c] = prm[c] / np.pi + prm[3 + c] * spec


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """Half vector by Walter's inversion (``ua`` → azimuth, ``ur`` → polar), reflected."""
    ax, ay = prm[6], prm[7]
    phi = np.arctan2(ay * np.sin(TWO_PI * ua), ax * np.cos(TWO_PI * ua))
    c, s = np.cos(phi), np.sin(phi)
    tan2 = -np.log(1.0 - ur) / (c * c / (ax * ax) + s * s / (ay * ay))
    ct = 1.0 / np.sqrt(1.0 + tan2)
    st = np.sqrt(max(0.0, 1.0 - ct * ct))
    return reflect_about(st * c, st * s, ct, vx, vy, vz)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` over ``s`` (1/sr)."""
    ax, ay = prm[6], prm[7]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    if norm == 0.0 or hz == 0.0:
        return 0.0
    # the sampled half vector is ±(s+v)/|s+v|, whichever lies in the upper hemisphere
    sign = 1.0 if hz > 0.0 else -1.0
    hx, hy, hz = sign * hx / norm, sign * hy / norm, sign * hz / norm
    sh = abs(sx * hx + sy * hy + sz * hz)
    if sh == 0.0:
        return 0.0
    ph = _gauss(ax, ay, hx, hy, hz) / (np.pi * ax * ay * hz * hz * hz)
    return ph / (4.0 * sh)
