"""A sphere light on a Lambert surface: the horizon-clipped irradiance of a uniform cap.

A light of angular radius ``σ`` about the unit direction ``d`` (a uniform spherical cap
of radiance ``L``, a sphere seen from afar) lights a plane of unit normal ``n`` with
(Snyder 1996, "Area light sources for real-time graphics", the sphere's form factor;
Lagarde & de Rousiers 2014, "Moving Frostbite to PBR", §4.7.2 eq. 17)::

    E = π L sin²σ cos θ                                    cos θ ≥ sin σ   (cap above the horizon)
    E = 0                                                  cos θ ≤ −sin σ  (below)
    E = L [(cos θ acos y − x sin θ √(1 − y²)) sin²σ + atan(sin θ √(1 − y²) / x)]   otherwise

with ``cos θ = n·d``, ``x = cot σ``, ``y = −x cot θ``. Per unit irradiance at normal
incidence ``a = π L sin²σ`` this is :func:`sphere_lambert`: ``max(0, n·d)`` away from the
horizon, rolling off over ``±σ`` about it where a point light has a kink. The light
carries ``L Ω = 2a/(1 + cos σ)`` of energy (:func:`sphere_power`), so its irradiance
integrates over all normals to ``π`` times that.

The third case is evaluated as ``[cos θ acos y + z + (atan z − z)/sin²σ]/π`` with
``z = sin θ √(1 − y²)/x``: the two terms of order ``sin σ`` that cancel in the paper's
form are taken out exactly, and ``(atan z − z)/sin²σ = z·(z²/sin²σ)·h(z²)`` with
``h(w) = (atan √w/√w − 1)/w`` (its series below ``w = 0.01``), so a light of radius
1e-6 rad shades as the point it is.
"""

import numpy as np

SERIES_BELOW = 0.01
"""``z²`` under which ``h`` is its four-term series (truncation below 1e-9)."""
TANGENT_NODES = 8
"""Gauss–Legendre nodes of :func:`sphere_tangent`'s band integral (relative error at most
1.1e-8 for radii up to 30°, against adaptive quadrature)."""


def sphere_power(radius) -> np.ndarray:
    """Energy ``L Ω`` of a sphere light per unit irradiance at normal incidence:
    ``2/(1 + cos σ)`` (1 for a point, 2 for a hemisphere); ``radius`` ``σ`` in radians."""
    return 2.0 / (1.0 + np.cos(np.asarray(radius, dtype=np.float64)))


def sphere_lambert(cos_theta, radius) -> np.ndarray:
    """Irradiance of a sphere light per unit irradiance at normal incidence (module
    docstring), dimensionless, in ``[0, 1]``.

    ``cos_theta``: ``n·d`` in ``[-1, 1]``; ``radius``: angular radius ``σ`` in radians,
    ``[0, π/2)`` (broadcast against ``cos_theta``); ``σ = 0`` is ``max(0, n·d)``.
    """
    c, sigma = np.broadcast_arrays(np.asarray(cos_theta, dtype=np.float64),
                                   np.asarray(radius, dtype=np.float64))  # fmt: skip
    shape = c.shape
    c, sigma = c.ravel(), sigma.ravel()
    out = np.maximum(c, 0.0)
    sin_s, cos_s = np.sin(sigma), np.cos(sigma)
    band = np.abs(c) < sin_s
    if not band.any():
        return out.reshape(shape)
    cb, sb, kb = c[band], sin_s[band], cos_s[band]
    sin_t = np.sqrt(1.0 - cb * cb)
    y = np.clip(-(kb / sb) * cb / sin_t, -1.0, 1.0)  # |y| < 1 but for rounding at the edges
    root = np.sqrt(np.maximum(0.0, 1.0 - y * y))
    z = sin_t * root * sb / kb
    w = z * z
    q = (sin_t * root / kb) ** 2  # z² / sin²σ
    safe = np.where(w < SERIES_BELOW, 1.0, w)
    h = np.where(
        w < SERIES_BELOW,
        -1.0 / 3.0 + w * (1.0 / 5.0 + w * (-1.0 / 7.0 + w / 9.0)),
        (np.arctan(np.sqrt(safe)) / np.sqrt(safe) - 1.0) / safe,
    )
    out[band] = (cb * np.arccos(y) + z + z * q * h) / np.pi
    return out.reshape(shape)


def sphere_tangent(cos_theta, radius) -> np.ndarray:
    """Kajiya–Kay diffuse factor of a sphere light per unit irradiance at normal incidence
    (Mehta et al. 2012's ``sqrt(1 − (t·s)²)/π²`` of a point, averaged over the cap):
    ``J(s, σ)/π²``, ``s = sqrt(1 − (t·d)²)``, dimensionless.

    ``|t × ω| = ¼ ∫₀^{2π} |u(φ)·ω| dφ`` over the unit vectors ``u ⊥ t``, and a cap's mean of
    ``max(0, u·ω)`` is :func:`sphere_lambert` over :func:`sphere_power`, so the energy
    factor cancels and ``J = ∫₀^{π/2} [K(s cos φ) + K(−s cos φ)] dφ`` (``K`` =
    :func:`sphere_lambert`): ``s sin φ₁`` where ``s cos φ ≥ sin σ`` (``K(x) + K(−x) = |x|``
    there), the rest by :data:`TANGENT_NODES`-point Gauss–Legendre. ``σ = 0``: ``s``.

    ``cos_theta``: ``t·d`` in ``[-1, 1]``; ``radius``: ``σ`` in radians, ``[0, π/2)``.
    """
    c, sigma = np.broadcast_arrays(np.asarray(cos_theta, dtype=np.float64),
                                   np.asarray(radius, dtype=np.float64))  # fmt: skip
    s = np.sqrt(np.maximum(0.0, 1.0 - c * c))
    b = np.sin(sigma)
    lit = s > b  # part of the circle of u sees the cap whole on one side
    start = np.where(lit, np.arccos(np.minimum(1.0, b / np.where(lit, s, 1.0))), 0.0)
    x, w = np.polynomial.legendre.leggauss(TANGENT_NODES)
    half = (np.pi / 2.0 - start) / 2.0
    phi = start[..., None] + half[..., None] * (x + 1.0)
    u = s[..., None] * np.cos(phi)
    band = sphere_lambert(u, sigma[..., None]) + sphere_lambert(-u, sigma[..., None])
    j = np.where(lit, s * np.sin(start), 0.0) + half * (band @ w)
    return j / (np.pi * np.pi)


def cap_band_factors(lmax: int, radius) -> np.ndarray:
    """``g_l = ⟨P_l⟩`` over a cap of angular ``radius`` (radians), ``l = 0 … lmax``: a
    sphere light's SH are a point light's of the same energy times ``g_l``,
    ``g_l = (P_{l−1}(cos σ) − P_{l+1}(cos σ)) / ((2l + 1)(1 − cos σ))`` (``g_0 = 1``;
    1 at ``σ = 0``). ``(lmax + 1,)`` for a scalar radius, ``(K, lmax + 1)`` for ``K``."""
    from scipy.special import eval_legendre

    sigma = np.asarray(radius, dtype=np.float64)
    x = np.cos(sigma)[..., None]
    l = np.arange(lmax + 1)
    one_minus = 1.0 - x
    small = one_minus < 1e-12
    p_lo = eval_legendre(np.maximum(l - 1, 0), x)
    p_hi = eval_legendre(l + 1, x)
    g = (p_lo - p_hi) / np.where(small, 1.0, (2 * l + 1) * one_minus)
    return np.where(small | (l == 0), 1.0, g)


def lights_sh(directions, irradiance, radii, lmax: int) -> np.ndarray:
    """``((lmax+1)², 3)`` radiance SH ``L_lm`` of lights (unit ``directions`` (K, 3),
    ``irradiance`` (K, 3) at normal incidence, angular ``radii`` (K,) in radians): a point's
    ``E_k y_lm(d_k)``, a sphere's of its energy :func:`sphere_power` times
    :func:`cap_band_factors` (exact for a uniform cap)."""
    from shbake.conventions import band_of_index
    from shbake.sh.basis import real_sh

    g = cap_band_factors(lmax, radii)[:, band_of_index(lmax)]
    energy = np.asarray(irradiance, dtype=np.float64) * sphere_power(radii)[:, None]
    return (real_sh(np.asarray(directions, dtype=np.float64), lmax) * g).T @ energy


__all__ = ["cap_band_factors", "lights_sh", "sphere_lambert", "sphere_power", "sphere_tangent"]
