"""Normalised Blinn–Phong BRDF (Blinn 1977; normalisation of Akenine-Möller et al.,
Real-Time Rendering 3rd ed., eq. 7.49).

``f(s, v) = ρ_d/π + ρ_s (n+8)/(8π) (n̂·h)^n``, ``h = (s+v)/|s+v|`` (1/sr).
The ``(n+8)/(8π)`` factor is an approximation: the measured albedo may
exceed ``ρ_s`` by a few per cent (recorded in the table asset).
Lobe sampling: half vector with density ``(n+1)/(2π) (n̂·h)^n``, reflected.
"""

import numpy as np

from shbake.brdf.phong import diffuse_and_lobe, line
from shbake.brdf.sampling import lobe_frame_dir, reflect_about, safe_pow
from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SPEC = ModelSpec(
    name="blinn-phong",
    model_id=2,
    params=(
        Param("rho_d", 0.0, 0.0, 1.0, colour=True, doc="diffuse albedo"),
        Param("rho_s", 1.0, 0.0, 1.0, colour=True, doc="specular scale"),
        Param("n", 64.0, 0.0, 1e6, doc="Blinn-Phong exponent"),
    ),
    citation="J. F. Blinn, Models of light reflection for computer synthesized pictures, "
    "SIGGRAPH 1977; normalisation: Akenine-Möller, Haines, Hoffman, Real-Time Rendering 3rd "
    "ed. (2008) eq. 7.49",
    summary="normalised Blinn-Phong half-vector lobe",
    energy=("rho_d", "rho_s"),
)


@jit
def _channels(prm, power, out):
    """``out[c] = ρ_d/π + ρ_s (n+8)/(8π) power``, ``power = (n̂·h)^n``."""
    diffuse_and_lobe(prm, (prm[6] + 8.0) / (8.0 * np.pi) * power, out)


@jit
def _density(n, power, vh):
    """The lobe density over ``s`` (1/sr): ``(n+1)/(2π) (n̂·h)^n / (4 |v·h|)``."""
    return (n + 1.0) / (2.0 * np.pi) * power / (4.0 * vh)


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (ρ_d[3], ρ_s[3], n)``."""
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    power = safe_pow(hz / norm, prm[6]) if norm > 0.0 else 0.0
    _channels(prm, power, out)


@jit
def evaluate_pdf(prm, sx, sy, sz, vx, vy, vz, out):
    """:func:`evaluate` into ``out`` and return :func:`pdf`, ``s_z, v_z > 0``: one power."""
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)  # > 0: s_z, v_z > 0
    hz /= norm
    power = safe_pow(hz, prm[6])
    _channels(prm, power, out)
    vh = abs(vx * hx + vy * hy + vz * hz * norm) / norm
    return _density(prm[6], power, vh) if vh != 0.0 else 0.0


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """Reflect ``v`` about a half vector drawn with density ``∝ (n̂·h)^n``."""
    return sample_on_line(prm, vx, vy, vz, ur, *line(ua))


@jit
def sample_on_line(prm, vx, vy, vz, ur, cphi, sphi):
    """:func:`sample` on the line ``(cphi, sphi) = line(u_a)`` (the half vector's azimuth)."""
    ct = ur ** (1.0 / (prm[6] + 1.0))
    hx, hy, hz = lobe_frame_dir(0.0, 0.0, 1.0, ct, cphi, sphi)
    return reflect_about(hx, hy, hz, vx, vy, vz)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` over ``s`` (1/sr): ``p_h(h) / (4 |v·h|)``, ``h = ±(s+v)/|s+v|``."""
    n = prm[6]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    if norm == 0.0:
        return 0.0
    hz /= norm
    vh = abs(vx * hx + vy * hy + vz * hz * norm) / norm
    if vh == 0.0:
        return 0.0
    # the sampled half vector is ±(s+v)/|s+v|, whichever lies in the upper hemisphere
    return _density(n, safe_pow(abs(hz), n), vh)
