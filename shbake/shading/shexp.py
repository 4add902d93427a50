"""SH-exponential glossy probe shading (Silvennoinen et al. 2025, §4).

``E0(v, n, r) ≈ P(ρ, r) Q(h_ρ, r)`` (eq. 9–11) with ``ρ = 2(n·v)n − v`` the
mirror direction, ``h_ρ = (n + ρ)/|n + ρ|``, and::

    P = exp(Σ_lm vMF_l(1/r) y_lm(ρ) p_lm),  Q = exp(Σ_lm vMF_l(1/r) y_lm(h_ρ) q_lm)
    vMF_l(κ) = exp(−l(l+1)/(2κ))                                    (eq. 12)

``q`` has no DC term. Full radiance: ``E = F0 E0 + (1 − F0) E0 A1/A0``
(eq. 5, 15; :mod:`shbake.shading.dfg`). Fitted by :mod:`shbake.bakers.shexp`.
"""

import numba
import numpy as np

from shbake.jit import pjit
from shbake.sh.basis import recurrence_tables, sh_eval_into
from shbake.shading.dfg import dfg_at


def vmf_factors(lmax: int, roughness) -> np.ndarray:
    """``vMF_l(1/r)`` per coefficient index, shape ``(…, (lmax+1)^2)`` (eq. 12)."""
    l = np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
    r = np.asarray(roughness, dtype=float)[..., None]
    return np.exp(-l * (l + 1) * r / 2.0)


def mirror_and_half(views, normals) -> tuple[np.ndarray, np.ndarray]:
    """``ρ = 2(n·v)n − v`` and ``h_ρ = (n + ρ)/|n + ρ|`` (eq. 10)."""
    nv = np.einsum("...i,...i->...", normals, views)[..., None]
    rho = 2.0 * nv * normals - views
    h = normals + rho
    return rho, h / np.linalg.norm(h, axis=-1, keepdims=True)


@pjit
def _evaluate(views, normals, roughness, f0, p, q, lmax_p, lmax_q, qmm, a, b, table, out):
    for k in numba.prange(views.shape[0]):
        yp = np.empty((lmax_p + 1) ** 2)
        yq = np.empty((lmax_q + 1) ** 2)
        vx, vy, vz = views[k, 0], views[k, 1], views[k, 2]
        nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
        nv = nx * vx + ny * vy + nz * vz
        rx, ry, rz = 2 * nv * nx - vx, 2 * nv * ny - vy, 2 * nv * nz - vz
        hx, hy, hz = nx + rx, ny + ry, nz + rz
        hn = np.sqrt(hx * hx + hy * hy + hz * hz)
        sh_eval_into(rx, ry, rz, lmax_p, qmm, a, b, yp)
        sh_eval_into(hx / hn, hy / hn, hz / hn, lmax_q, qmm, a, b, yq)
        r = roughness[k]
        a0, a1 = dfg_at(table, nv, r)
        tail = a1 / a0 if a0 > 0.0 else 0.0
        for c in range(3):
            s = 0.0
            for l in range(lmax_p + 1):
                g = np.exp(-l * (l + 1) * r / 2.0)
                for i in range(l * l, (l + 1) * (l + 1)):
                    s += g * yp[i] * p[i, c]
            for l in range(1, lmax_q + 1):
                g = np.exp(-l * (l + 1) * r / 2.0)
                for i in range(l * l, (l + 1) * (l + 1)):
                    s += g * yq[i] * q[i - 1, c]
            e0 = np.exp(s)
            out[k, c] = f0[c] * e0 + (1.0 - f0[c]) * e0 * tail


def evaluate_shexp(p, q, table, views, normals, roughness, f0=(1.0, 1.0, 1.0)) -> np.ndarray:
    """Outgoing radiance ``(T, 3)`` of an SH-exp probe at world ``(v, n, r)``.

    ``f0``: Schlick reflectance per channel (1 = chrome: ``E0`` alone).
    Roughness must lie in the probe's fitted range; the caller checks it.
    """
    p = np.asarray(p, float)
    q = np.asarray(q, float)
    lmax_p = int(round(np.sqrt(p.shape[0]))) - 1
    lmax_q = int(round(np.sqrt(q.shape[0] + 1))) - 1
    v = np.ascontiguousarray(np.asarray(views, float).reshape(-1, 3))
    n = np.ascontiguousarray(np.asarray(normals, float).reshape(-1, 3))
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(roughness, float), (v.shape[0],)))
    out = np.empty((v.shape[0], 3))
    f0 = np.broadcast_to(np.asarray(f0, float), (3,)).copy()
    qmm, a, b = recurrence_tables(max(lmax_p, lmax_q))
    _evaluate(v, n, r, f0, p, q, lmax_p, lmax_q, qmm, a, b, np.asarray(table, float), out)
    return out
