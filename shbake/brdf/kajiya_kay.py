"""Kajiya–Kay fibre BRDF (Kajiya & Kay 1989, §3.3) for fibres along the tangent ``t = +X``.

As a surface BRDF in Kautz et al.'s framework (the product function adds
``max(0, s_z)``)::

    f = k_d sin(t, s) / π + k_s (p+2)/(2π) max(0, sin(t,s) sin(t,v) − (t·s)(t·v))^p

The specular term peaks on the cone of mirror directions about the fibre
(``angle(t, s) = π − angle(t, v)``); the ``(p+2)/(2π)`` factor is a Phong-like
normalisation, so the albedo is measured and recorded, not guaranteed ≤ 1.
Lobe sampling: the angle to the fibre is drawn about the cone from a logistic
density of scale ``0.551/√p`` (≈ the width of ``cos^p``) truncated to
``[0, π]``, the azimuth about the fibre uniformly.
"""

import numpy as np

from shbake.brdf.sampling import TWO_PI, safe_pow
from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SPEC = ModelSpec(
    name="kajiya-kay",
    model_id=6,
    params=(
        Param("kd", 0.5, 0.0, 1.0, colour=True, doc="diffuse coefficient"),
        Param("ks", 0.5, 0.0, 1.0, colour=True, doc="specular coefficient"),
        Param("p", 32.0, 0.0, 1e6, doc="specular exponent"),
    ),
    citation="J. T. Kajiya, T. L. Kay, Rendering fur with three dimensional textures, "
    "SIGGRAPH 1989",
    summary="hair/fibre model: diffuse sin(t,s) and a specular cone about the fibre",
    energy=("kd", "ks"),
    isotropic=False,
)


@jit
def _scale(p):
    return 0.551 / np.sqrt(max(p, 1.0))


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (k_d[3], k_s[3], p)``."""
    p = prm[6]
    sin_s = np.sqrt(max(0.0, 1.0 - sx * sx))
    sin_v = np.sqrt(max(0.0, 1.0 - vx * vx))
    spec = (p + 2.0) / (2.0 * np.pi) * safe_pow(sin_s * sin_v - sx * vx, p)
    for c in range(3):
        out[c] = prm[c] * sin_s / np.pi + prm[3 + c] * spec


@jit
def _logistic_cdf(x, s):
    return 1.0 / (1.0 + np.exp(-x / s))


@jit
def _span(vx, s):
    """Cone angle ``θ*`` and the logistic CDF at the ends of ``θ ∈ [0, π]``."""
    centre = np.pi - np.arccos(min(1.0, max(-1.0, vx)))
    return centre, _logistic_cdf(-centre, s), _logistic_cdf(np.pi - centre, s)


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """Angle to the fibre: logistic about the cone, truncated to ``[0, π]``; azimuth uniform."""
    s = _scale(prm[6])
    centre, f0, f1 = _span(vx, s)
    u = min(max(f0 + ur * (f1 - f0), 1e-300), 1.0 - 1e-16)
    theta = min(max(centre + s * np.log(u / (1.0 - u)), 0.0), np.pi)
    st = np.sin(theta)
    psi = TWO_PI * ua
    return np.cos(theta), st * np.cos(psi), st * np.sin(psi)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` over ``s`` (1/sr)."""
    s = _scale(prm[6])
    st = np.sqrt(max(0.0, 1.0 - sx * sx))
    if st <= 1e-12:
        return 0.0
    centre, f0, f1 = _span(vx, s)
    d = (np.arccos(min(1.0, max(-1.0, sx))) - centre) / s
    e = np.exp(-abs(d))
    return e / (s * (1.0 + e) ** 2) / (f1 - f0) / (TWO_PI * st)
