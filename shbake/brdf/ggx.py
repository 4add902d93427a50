"""Cook–Torrance microfacet BRDF with the GGX distribution and Smith shadowing.

``f(s, v) = F(s·h) D(h) G(s, v) / (4 s_z v_z)`` (Cook & Torrance 1982), with
(Walter et al. 2007 eq. 33–34, anisotropic form of Heitz 2014 eq. 85–86)::

    D(h)  = 1 / (π α_x α_y (h_x²/α_x² + h_y²/α_y² + h_z²)²)
    Λ(w)  = (−1 + sqrt(1 + (α_x² w_x² + α_y² w_y²)/w_z²)) / 2
    G     = G1(s) G1(v), G1 = 1/(1+Λ)      (separable, as Mitsuba 3; SPEC §4)
          = 1/(1 + Λ(s) + Λ(v))            (height-correlated, ``correlated=1``)
    F     = F0 + (1 − F0)(1 − s·h)^5       (Schlick)

``α`` is the microfacet width of Walter et al. (SPEC §1), not perceptual roughness.
Lobe sampling: distribution of visible normals (Heitz 2018), density
``G1(v) D(h) / (4 v_z)`` over ``s``.
"""

import numpy as np

from shbake.brdf.sampling import TWO_PI, reflect_about
from shbake.brdf.spec import ModelSpec, Param
from shbake.conventions import ROUGHNESS_MIN, check_roughness
from shbake.errors import ParameterError
from shbake.jit import jit

SPEC = ModelSpec(
    name="ggx",
    model_id=5,
    params=(
        Param("F0", 1.0, 0.0, 1.0, colour=True, doc="Fresnel reflectance at normal incidence"),
        Param("alpha_x", 0.3, 1e-4, 1.0, doc="GGX width along the tangent (+X)"),
        Param("alpha_y", 0.3, 1e-4, 1.0, doc="GGX width along the bitangent (+Y)"),
        Param("correlated", 0.0, 0.0, 1.0, doc="1: height-correlated Smith G, 0: separable"),
    ),
    citation="R. L. Cook, K. E. Torrance, ACM TOG 1(1) 1982; B. Walter et al., Microfacet "
    "models for refraction through rough surfaces, EGSR 2007; E. Heitz, Understanding the "
    "masking-shadowing function, JCGT 3(2) 2014; E. Heitz, Sampling the GGX distribution of "
    "visible normals, JCGT 7(4) 2018",
    summary="Cook-Torrance GGX microfacet with Smith G and Schlick Fresnel",
    isotropic=False,
    aliases={"alpha": ("alpha_x", "alpha_y")},
)


@jit
def ggx_d(ax, ay, hx, hy, hz):
    """GGX normal distribution ``D(h)`` (1/sr), ``h`` unit, ``h_z > 0``."""
    t = (hx / ax) ** 2 + (hy / ay) ** 2 + hz * hz
    return 1.0 / (np.pi * ax * ay * t * t)


@jit
def ggx_d_iso(a2, cos_h):
    """Isotropic GGX ``D`` (1/sr) of width ``α`` (``a2 = α²``) at ``cos θ_h = n·h > 0``:
    ``α² / (π ((α² − 1) cos²θ_h + 1)²)`` — :func:`ggx_d` with ``α_x = α_y`` written in
    ``cos θ_h`` (Walter et al. 2007 eq. 33, ``tan²θ = 1/cos²θ − 1``).

    >>> round(ggx_d_iso(0.25, 1.0) * 0.25 * np.pi, 12)  # D(n) = 1/(π α²)
    1.0
    """
    q = (cos_h * cos_h) * (a2 - 1.0) + 1.0
    return a2 / (np.pi * q * q)


@jit
def half_vector_cos2(a2, u):
    """``cos²θ_h`` of the GGX half vector drawn with density ``D(h) cos θ_h`` from
    ``u ∈ [0, 1)`` (width ``α``, ``a2 = α²``): the inverted CDF of Walter et al. 2007
    eq. 35, ``tan²θ_h = α² u / (1 − u)``.

    >>> half_vector_cos2(0.25, 0.0), half_vector_cos2(0.25, 0.8)
    (1.0, 0.5)
    """
    return (1.0 - u) / (1.0 + (a2 - 1.0) * u)


@jit
def smith_lambda(ax, ay, wx, wy, wz):
    """Smith ``Λ(w)`` for GGX, ``w_z > 0``."""
    a2 = (ax * ax * wx * wx + ay * ay * wy * wy) / (wz * wz)
    return 0.5 * (np.sqrt(1.0 + a2) - 1.0)


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (F0[3], α_x, α_y, correlated)``."""
    ax, ay = prm[3], prm[4]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    if sz <= 0.0 or vz <= 0.0 or norm == 0.0:
        for c in range(3):
            out[c] = 0.0
        return
    hx, hy, hz = hx / norm, hy / norm, hz / norm
    sh = max(sx * hx + sy * hy + sz * hz, 0.0)
    ls, lv = smith_lambda(ax, ay, sx, sy, sz), smith_lambda(ax, ay, vx, vy, vz)
    if prm[5] > 0.5:
        g = 1.0 / (1.0 + ls + lv)
    else:
        g = 1.0 / ((1.0 + ls) * (1.0 + lv))
    base = ggx_d(ax, ay, hx, hy, hz) * g / (4.0 * sz * vz)
    fk = (1.0 - sh) ** 5
    for c in range(3):
        out[c] = base * (prm[c] + (1.0 - prm[c]) * fk)


@jit
def vndf_frame(ax, ay, vx, vy, vz):
    """The part of :func:`sample` that depends on the view alone: the stretched view ``w``
    and the frame ``t1``, ``t2`` about it (Heitz 2018, listing 1), as one 9-tuple."""
    wx, wy, wz = ax * vx, ay * vy, vz
    n = np.sqrt(wx * wx + wy * wy + wz * wz)
    wx, wy, wz = wx / n, wy / n, wz / n
    lensq = wx * wx + wy * wy
    if lensq > 0.0:
        inv = 1.0 / np.sqrt(lensq)
        t1x, t1y, t1z = -wy * inv, wx * inv, 0.0
    else:
        t1x, t1y, t1z = 1.0, 0.0, 0.0
    t2x, t2y, t2z = wy * t1z - wz * t1y, wz * t1x - wx * t1z, wx * t1y - wy * t1x
    return wx, wy, wz, t1x, t1y, t1z, t2x, t2y, t2z


@jit
def sample_in_frame(ax, ay, vx, vy, vz, frame, ur, ua):
    """:func:`sample` given the view's :func:`vndf_frame` (computed once per view)."""
    wx, wy, wz, t1x, t1y, t1z, t2x, t2y, t2z = frame
    r = np.sqrt(ur)
    phi = TWO_PI * ua
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    blend = 0.5 * (1.0 + wz)
    p2 = (1.0 - blend) * np.sqrt(max(0.0, 1.0 - p1 * p1)) + blend * p2
    p3 = np.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx = p1 * t1x + p2 * t2x + p3 * wx
    ny = p1 * t1y + p2 * t2y + p3 * wy
    nz = p1 * t1z + p2 * t2z + p3 * wz
    hx, hy, hz = ax * nx, ay * ny, max(nz, 0.0)
    n = np.sqrt(hx * hx + hy * hy + hz * hz)
    if n == 0.0:
        return 0.0, 0.0, -1.0
    return reflect_about(hx / n, hy / n, hz / n, vx, vy, vz)


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """Visible-normal sample (Heitz 2018, listing 1), reflected."""
    ax, ay = prm[3], prm[4]
    return sample_in_frame(ax, ay, vx, vy, vz, vndf_frame(ax, ay, vx, vy, vz), ur, ua)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` over ``s`` (1/sr): ``G1(v) D(h) / (4 v_z)``."""
    ax, ay = prm[3], prm[4]
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    norm = np.sqrt(hx * hx + hy * hy + hz * hz)
    if norm == 0.0 or vz <= 0.0:
        return 0.0
    hx, hy, hz = hx / norm, hy / norm, hz / norm
    if hz <= 0.0 or sx * hx + sy * hy + sz * hz <= 0.0:
        return 0.0
    g1 = 1.0 / (1.0 + smith_lambda(ax, ay, vx, vy, vz))
    return g1 * ggx_d(ax, ay, hx, hy, hz) / (4.0 * vz)


@jit
def view_g1(vx, vy, vz, alpha):
    """``G1(v)`` of an isotropic GGX of width ``α`` (local ``v``, ``v_z > 0``)."""
    return 1.0 / (1.0 + smith_lambda(alpha, alpha, vx, vy, vz))


@jit
def vndf_terms_at(g1v, vx, vy, vz, lx, ly, lz, alpha):
    """:func:`vndf_terms` given ``G1(v)`` (:func:`view_g1`, computed once per view)."""
    hx, hy, hz = vx + lx, vy + ly, vz + lz
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / hn, hy / hn, hz / hn
    g1l = 1.0 / (1.0 + smith_lambda(alpha, alpha, lx, ly, lz))
    tail = (1.0 - min(1.0, max(0.0, vx * hx + vy * hy + vz * hz))) ** 5
    return g1v * ggx_d(alpha, alpha, hx, hy, hz) / (4.0 * vz), g1l, tail


@jit
def vndf_terms(vx, vy, vz, lx, ly, lz, alpha):
    """For local unit ``v``, ``l`` above the surface of an isotropic GGX of width ``α``: the
    visible-normal density ``p(l) = G1(v) D(h) / (4 n·v)`` (1/sr), ``G1(l)`` and the Schlick
    tail ``(1 − v·h)^5``. ``f_DV (n·l) = p(l) G1(l)`` (separable Smith, SPEC §4)."""
    return vndf_terms_at(view_g1(vx, vy, vz, alpha), vx, vy, vz, lx, ly, lz, alpha)


@jit
def sample_light_at(t, b, n, v_loc, alpha, frame, g1v, ur, ua):
    """:func:`sample_light` given the view's :func:`vndf_frame` and :func:`view_g1`."""
    sx, sy, sz = sample_in_frame(alpha, alpha, v_loc[0], v_loc[1], v_loc[2], frame, ur, ua)
    if sz <= 0.0:
        return 0.0, 0.0, 1.0, 0.0, 0.0, 1.0
    pdf, g1, tail = vndf_terms_at(g1v, v_loc[0], v_loc[1], v_loc[2], sx, sy, sz, alpha)
    wx = sx * t[0] + sy * b[0] + sz * n[0]
    wy = sx * t[1] + sy * b[1] + sz * n[1]
    wz = sx * t[2] + sy * b[2] + sz * n[2]
    return wx, wy, wz, g1, g1 * tail, pdf


@jit
def sample_light(t, b, n, v_loc, alpha, prm, ur, ua):
    """One visible-normal sample in the world frame ``(t, b, n)`` of
    :func:`shbake.brdf.sampling.surface_frame`: world ``l``, weights ``G1(l)`` and
    ``G1(l) (1 − v·h)^5``, and the density ``p(l)`` of :func:`vndf_terms` (1/sr).

    ``prm`` is a scratch GGX parameter vector with ``prm[3] = prm[4] = α``.
    The weights are 0 when ``l`` falls below the surface.
    """
    frame = vndf_frame(prm[3], prm[4], v_loc[0], v_loc[1], v_loc[2])
    g1v = view_g1(v_loc[0], v_loc[1], v_loc[2], alpha)
    return sample_light_at(t, b, n, v_loc, alpha, frame, g1v, ur, ua)


def check_geometry(views, normals, roughness):
    """Validate world shading geometry: unit ``views``/``normals`` ``(T, 3)`` with ``n·v > 0``
    and perceptual ``roughness`` (scalar or ``(T,)``) in ``[ROUGHNESS_MIN, 1]``; returns
    contiguous float64 ``(v, n, r)``."""
    v = np.ascontiguousarray(np.asarray(views, dtype=float).reshape(-1, 3))
    n = np.ascontiguousarray(np.asarray(normals, dtype=float).reshape(-1, 3))
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(roughness, float), (v.shape[0],)))
    if v.shape != n.shape:
        raise ParameterError("views and normals must have the same number of directions")
    for name, d in (("views", v), ("normals", n)):
        if np.any(np.abs(np.linalg.norm(d, axis=1) - 1.0) > 1e-6):
            raise ParameterError(f"{name} must be unit vectors")
    if np.any(np.einsum("ij,ij->i", v, n) <= 0.0):
        raise ParameterError("every view must lie above its surface (n·v > 0)")
    check_roughness(r, ROUGHNESS_MIN)
    return v, n, r
