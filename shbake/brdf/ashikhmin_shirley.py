"""Ashikhmin–Shirley anisotropic Phong BRDF (Ashikhmin & Shirley 2000, eq. 4–5).

Tangent ``u = +X``, bitangent ``v̂ = +Y``, normal ``n = +Z``; ``k1 = s``, ``k2 = v``,
``h = (k1+k2)/|k1+k2|``, ``k = k1`` (``k·h = k2·h``)::

    ρ_s = sqrt((n_u+1)(n_v+1))/(8π) (n·h)^e / ((k·h) max(n·k1, n·k2)) F(k·h)
    e   = (n_u (h·u)² + n_v (h·v̂)²) / (1 − (h·n)²)
    F   = R_s + (1 − R_s)(1 − k·h)^5                    (Schlick)
    ρ_d = 28 R_d/(23π) (1 − R_s)(1 − (1 − n·k1/2)^5)(1 − (1 − n·k2/2)^5)

Energy-conserving by construction for ``R_s, R_d ∈ [0, 1]``. Lobe sampling:
the paper's half-vector distribution (eq. 9–10), density
``sqrt((n_u+1)(n_v+1))/(2π) (n·h)^e``, reflected (``p_s = p_h / (4 k·h)``).
"""

import numpy as np

from shbake.brdf.sampling import reflect_about, safe_pow
from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SPEC = ModelSpec(
    name="ashikhmin-shirley",
    model_id=3,
    params=(
        Param("nu", 24.0, 0.0, 1e6, doc="exponent along the tangent (+X)"),
        Param("nv", 8.0, 0.0, 1e6, doc="exponent along the bitangent (+Y)"),
        Param("Rs", 1.0, 0.0, 1.0, colour=True, doc="specular reflectance at normal incidence"),
        Param("Rd", 0.0, 0.0, 1.0, colour=True, doc="diffuse reflectance"),
    ),
    citation="M. Ashikhmin, P. Shirley, An anisotropic Phong BRDF model, "
    "Journal of Graphics Tools 5(2):25-32 (2000)",
    summary="anisotropic Phong lobe with Schlick Fresnel and a coupled diffuse term",
    isotropic=False,
)


@jit
def _exponent(nu, nv, hx, hy, hz):
    t = hx * hx + hy * hy
    if t <= 1e-300:
        return 0.5 * (nu + nv)
    return (nu * hx * hx + nv * hy * hy) / t


@jit
def _specular(nu, nv, power, kh, sz, vz):
    """The specular term without Fresnel, ``power = (n·h)^e``, ``kh = k·h > 0`` (1/sr)."""
    return np.sqrt((nu + 1.0) * (nv + 1.0)) / (8.0 * np.pi) * power / (kh * max(sz, vz))


@jit
def _density(nu, nv, power, kh):
    """The lobe density over ``s`` (1/sr): ``p_h / (4 |k·h|)``, ``power = (n·h)^e``."""
    ph = np.sqrt((nu + 1.0) * (nv + 1.0)) / (2.0 * np.pi) * power
    return ph / (4.0 * kh)


@jit
def _channels(prm, spec, kh, sz, vz, out):
    """``out[c] = ρ_s F + ρ_d`` from the specular term ``spec`` (``kh``: ``k·h``, Schlick)."""
    fk = (1.0 - kh) ** 5 if spec > 0.0 else 0.0
    dk = (1.0 - (1.0 - 0.5 * sz) ** 5) * (1.0 - (1.0 - 0.5 * vz) ** 5) * 28.0 / (23.0 * np.pi)
    for c in range(3):
        rs, rd = prm[2 + c], prm[5 + c]
        out[c] = spec * (rs + (1.0 - rs) * fk) + rd * (1.0 - rs) * dk


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (n_u, n_v, R_s[3], R_d[3])``."""
    nu, nv = prm[0], prm[1]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    spec = 0.0
    kh = 0.0
    if norm > 0.0:
        hx, hy, hz = hx / norm, hy / norm, hz / norm
        kh = sx * hx + sy * hy + sz * hz
        if kh > 0.0 and hz > 0.0:
            spec = _specular(nu, nv, safe_pow(hz, _exponent(nu, nv, hx, hy, hz)), kh, sz, vz)
    _channels(prm, spec, kh, sz, vz, out)


@jit
def evaluate_pdf(prm, sx, sy, sz, vx, vy, vz, out):
    """:func:`evaluate` into ``out`` and return :func:`pdf`, for ``s_z, v_z > 0``: both
    share ``(n·h)^e``, computed once (bit-identical to the two calls)."""
    nu, nv = prm[0], prm[1]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / norm, hy / norm, hz / norm  # norm > 0, h_z > 0: s_z, v_z > 0
    kh = sx * hx + sy * hy + sz * hz
    spec = 0.0
    p = 0.0
    if kh != 0.0:
        power = safe_pow(hz, _exponent(nu, nv, hx, hy, hz))
        p = _density(nu, nv, power, abs(kh))
        if kh > 0.0:
            spec = _specular(nu, nv, power, kh, sz, vz)
    _channels(prm, spec, kh, sz, vz, out)
    return p


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """Half vector from the paper's eq. 9–10 (``ua`` → azimuth by quadrant, ``ur`` → polar)."""
    return sample_on_line(prm, vx, vy, vz, ur, *line(prm, ua))


@jit
def line(prm, ua):
    """The part of :func:`sample` fixed by ``u_a``: ``cos φ, sin φ`` of the half vector (eq. 9)."""
    nu, nv = prm[0], prm[1]
    q = min(int(4.0 * ua), 3)
    xi = 4.0 * ua - q
    if q == 1 or q == 3:
        xi = 1.0 - xi  # mirrored quadrants keep φ(u_a) continuous
    phi = np.arctan(np.sqrt((nu + 1.0) / (nv + 1.0)) * np.tan(0.5 * np.pi * xi))
    if q == 1:
        phi = np.pi - phi
    elif q == 2:
        phi = np.pi + phi
    elif q == 3:
        phi = 2.0 * np.pi - phi
    return np.cos(phi), np.sin(phi)


@jit
def sample_on_line(prm, vx, vy, vz, ur, c, s):
    """:func:`sample` on the line ``(c, s) = line(prm, u_a)``: the polar angle (eq. 10)."""
    nu, nv = prm[0], prm[1]
    ct = (1.0 - ur) ** (1.0 / (nu * c * c + nv * s * s + 1.0))
    st = np.sqrt(max(0.0, 1.0 - ct * ct))
    return reflect_about(st * c, st * s, ct, vx, vy, vz)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` over ``s`` (1/sr)."""
    nu, nv = prm[0], prm[1]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    if norm == 0.0:
        return 0.0
    # the sampled half vector is ±(s+v)/|s+v|, whichever lies in the upper hemisphere
    sign = 1.0 if hz >= 0.0 else -1.0
    hx, hy, hz = sign * hx / norm, sign * hy / norm, sign * hz / norm
    kh = abs(sx * hx + sy * hy + sz * hz)
    if kh == 0.0:
        return 0.0
    return _density(nu, nv, safe_pow(hz, _exponent(nu, nv, hx, hy, hz)), kh)
