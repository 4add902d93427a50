"""Energy-normalised Phong BRDF (Lafortune & Willems 1994).

``f(s, v) = ρ_d/π + ρ_s (n+2)/(2π) max(0, r·s)^n`` with ``r = (−v_x, −v_y, v_z)``
the mirror direction of ``v`` (1/sr). Its specular albedo at normal incidence
is exactly ``ρ_s``; at other views less (the lobe is clipped by the horizon),
so ``ρ_d + ρ_s ≤ 1`` conserves energy.
Lobe sampling: ``cos α = u^{1/(n+1)}`` about ``r``, density ``(n+1)/(2π) cos^n α``.
"""

import numpy as np

from shbake.brdf.sampling import TWO_PI, lobe_frame_dir, safe_pow
from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SPEC = ModelSpec(
    name="phong",
    model_id=1,
    params=(
        Param("rho_d", 0.0, 0.0, 1.0, colour=True, doc="diffuse albedo"),
        Param("rho_s", 1.0, 0.0, 1.0, colour=True, doc="specular albedo at normal incidence"),
        Param("n", 32.0, 0.0, 1e6, doc="Phong exponent"),
    ),
    citation="E. Lafortune, Y. Willems, Using the modified Phong reflectance model "
    "for physically based rendering, KU Leuven CW197 (1994)",
    summary="normalised Phong lobe about the mirror direction",
    energy=("rho_d", "rho_s"),
)


@jit
def _mirror_power(n, sx, sy, sz, vx, vy, vz):
    """``max(0, r·s)^n``, ``r = (−v_x, −v_y, v_z)``: the lobe shared by value and density."""
    return safe_pow(-vx * sx - vy * sy + vz * sz, n)


@jit
def diffuse_and_lobe(prm, lobe, out):
    """``out[c] = ρ_d/π + ρ_s lobe`` for ``prm = (ρ_d[3], ρ_s[3], …)`` (also Blinn–Phong's)."""
    for c in range(3):
        out[c] = prm[c] / np.pi + prm[3 + c] * lobe


@jit
def _channels(prm, power, out):
    """``out[c] = ρ_d/π + ρ_s (n+2)/(2π) power``."""
    diffuse_and_lobe(prm, (prm[6] + 2.0) / (2.0 * np.pi) * power, out)


@jit
def _mirror_density(n, power):
    """The lobe density ``(n+1)/(2π) cos^n α`` from ``power = cos^n α`` (1/sr)."""
    return (n + 1.0) / (2.0 * np.pi) * power


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (ρ_d[3], ρ_s[3], n)``."""
    _channels(prm, _mirror_power(prm[6], sx, sy, sz, vx, vy, vz), out)


@jit
def evaluate_pdf(prm, sx, sy, sz, vx, vy, vz, out):
    """:func:`evaluate` into ``out`` and return :func:`pdf`: one power for both."""
    power = _mirror_power(prm[6], sx, sy, sz, vx, vy, vz)
    _channels(prm, power, out)
    return _mirror_density(prm[6], power)


@jit
def mirror_lobe_sample(n, vx, vy, vz, ur, ua):
    """Direction with density ``(n+1)/(2π) cos^n α`` about the mirror direction of ``v``."""
    return _mirror_sample_cs(n, vx, vy, vz, ur, *line(ua))


@jit
def _mirror_sample_cs(n, vx, vy, vz, ur, cphi, sphi):
    """:func:`mirror_lobe_sample` with the azimuth's cosine and sine given."""
    ct = ur ** (1.0 / (n + 1.0))
    return lobe_frame_dir(-vx, -vy, vz, ct, cphi, sphi)


@jit
def line(ua):
    """The part of :func:`sample` fixed by ``u_a``: ``cos, sin`` of the azimuth ``2π u_a``."""
    phi = TWO_PI * ua
    return np.cos(phi), np.sin(phi)


@jit
def sample_on_line(prm, vx, vy, vz, ur, cphi, sphi):
    """:func:`sample` on the line ``(cphi, sphi) = line(u_a)``."""
    return _mirror_sample_cs(prm[6], vx, vy, vz, ur, cphi, sphi)


@jit
def mirror_lobe_pdf(n, sx, sy, sz, vx, vy, vz):
    """Density of :func:`mirror_lobe_sample` (1/sr)."""
    return _mirror_density(n, _mirror_power(n, sx, sy, sz, vx, vy, vz))


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """A direction from the lobe density about the mirror direction."""
    return mirror_lobe_sample(prm[6], vx, vy, vz, ur, ua)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` (1/sr)."""
    return mirror_lobe_pdf(prm[6], sx, sy, sz, vx, vy, vz)
