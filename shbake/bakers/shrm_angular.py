"""Angular-domain baseline of Ramamoorthi & Hanrahan (2002): hemispherical integration per texel.

For every output texel ``R`` of a cube map and every view ``V`` the reflected
radiance is summed over the texels of the lat-long map directly::

    B(R, V) = Σ_{d : R·d ≥ cos θ*} L(d) ρ̂(d; R, V) Ω(d)

with ``ρ̂ = f(d, V) max(0, n·d)``, ``n = (R+V)/|R+V|`` in the frame of ``n``
(:func:`shbake.brdf.dispatch.brdf_eval`), or ``(s+1)/(2π) max(0, R·d)^s`` for
the radially symmetric ``phong-lobe`` (then ``B(R)`` has no ``V``). Only the
map rows and columns that can hold directions within ``θ*`` of ``R`` are
visited, so the cost per texel is ``W S_L²`` (§6.2, Table 3).

Angular truncation (appendix D): ``θ*`` is the smallest angle about ``R``
holding ``1 − ε`` of ``∫ ρ̂ dω_i``. Phong lobe: ``cos θ* = ε^{1/(s+1)}``;
other BRDFs: from the azimuth-integrated ``ρ̂`` on a Gauss–Legendre grid in
``cos θ_i``, tabulated over ``cos θ_o = R·V`` and read conservatively (the
larger of the two neighbouring entries). ``ε → 0`` gives the full hemisphere
(the exact texel sum).
"""

import numpy as np

from shbake.brdf.dispatch import brdf_eval
from shbake.brdf.reflection import ReflectionBRDF, check_eps, rho_grid
from shbake.brdf.sampling import tangent_frame
from shbake.envmap.layouts import latlong_solid_angles
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.point_sets import gauss_legendre

N_TSTAR = 129
"""Entries of the ``θ*(cos θ_o)`` table (uniform in ``cos θ_o``)."""


def truncation_angles(rb: ReflectionBRDF, eps: float, n_theta_i: int = 512) -> np.ndarray:
    """``cos θ*`` per entry of a uniform grid of ``cos θ_o`` over [−1, 1] (``N_TSTAR``,)."""
    eps = check_eps(eps) if eps > 0 else 0.0
    if rb.kind == "lobe":
        s = float(rb.values["s"])
        return np.full(N_TSTAR, eps ** (1.0 / (s + 1.0)) if eps > 0 else -1.0)
    if eps == 0.0:
        return np.full(N_TSTAR, -1.0)
    xi, wi = gauss_legendre(n_theta_i)
    xo = np.linspace(-1.0 + 1e-6, 1.0 - 1e-6, N_TSTAR)
    phi = np.linspace(0.0, np.pi, 65)
    wphi = np.full(phi.size, np.pi / 64)
    wphi[[0, -1]] *= 0.5
    grid = np.zeros((xi.size, xo.size, phi.size, 3))
    rho_grid(rb.kind_id, rb.model_id, np.ascontiguousarray(rb.prm, float), rb.data, xi, xo, phi,
              grid)  # fmt: skip
    lum = np.einsum("iokc,k->io", grid, wphi) * wi[:, None]  # ∫ ρ̂ dφ dcosθ_i, all channels
    order = np.argsort(-xi)  # from θ_i = 0 outward
    cum = np.cumsum(lum[order], axis=0)
    total = cum[-1]
    out = np.empty(N_TSTAR)
    for o in range(N_TSTAR):
        if total[o] <= 0.0:
            out[o] = 1.0
            continue
        k = int(np.searchsorted(cum[:, o], (1.0 - eps) * total[o]))
        k = min(k + 1, xi.size - 1)  # one node of margin
        out[o] = xi[order][k]
    return out


@jit
def _angular(kind, model, prm, data, R, V, ct_table, pixels, row_omega, sphi, cphi, out, b0, b1):
    H, W = pixels.shape[0], pixels.shape[1]
    nt = ct_table.shape[0]
    for t in range(b0, b1):
        f = np.empty(3)
        rx, ry, rz = R[t, 0], R[t, 1], R[t, 2]
        th_r = np.arccos(min(1.0, max(-1.0, ry)))
        ph_r = np.arctan2(rx, -rz)
        for k in range(V.shape[0]):
            vx, vy, vz = V[k, 0], V[k, 1], V[k, 2]
            xo = rx * vx + ry * vy + rz * vz
            pos = (xo + 1.0) * 0.5 * (nt - 1)
            i0 = min(max(int(pos), 0), nt - 2)
            ct = min(ct_table[i0], ct_table[i0 + 1])
            nx, ny, nz = rx + vx, ry + vy, rz + vz
            nn = np.sqrt(nx * nx + ny * ny + nz * nz)
            if kind == 0 and nn < 1e-12:
                continue
            if kind == 0:
                nx, ny, nz = nx / nn, ny / nn, nz / nn
            (tx, ty, tz), (bx, by, bz) = tangent_frame(nx, ny, nz)
            lvx = vx * tx + vy * ty + vz * tz
            lvy = vx * bx + vy * by + vz * bz
            lvz = vx * nx + vy * ny + vz * nz
            ts = np.arccos(min(1.0, max(-1.0, ct)))
            r0 = max(int(np.floor((th_r - ts) / np.pi * H)), 0)
            r1 = min(int(np.ceil((th_r + ts) / np.pi * H)), H - 1)
            a0 = a1 = a2 = 0.0
            for i in range(r0, r1 + 1):
                th = np.pi * (i + 0.5) / H
                st, cth = np.sin(th), np.cos(th)
                den = st * np.sin(th_r)
                full = True
                dphi = np.pi
                if den > 1e-12:
                    c = (ct - cth * ry) / den
                    if c > 1.0:
                        # the cap misses this row's centre line; keep a margin of one row
                        c = 1.0
                    if c > -1.0:
                        full = False
                        dphi = np.arccos(c) + 2.0 * np.pi / W + np.pi / H
                if full or dphi >= np.pi:
                    j0, j1 = 0, W - 1
                else:
                    j0 = int(np.floor((ph_r - dphi) / (2.0 * np.pi) * W - 0.5))
                    j1 = int(np.ceil((ph_r + dphi) / (2.0 * np.pi) * W - 0.5))
                for jj in range(j0, j1 + 1):
                    j = jj % W
                    dx, dy, dz = st * sphi[j], cth, -st * cphi[j]
                    crl = rx * dx + ry * dy + rz * dz
                    if crl < ct:
                        continue
                    if kind == 1:
                        s = prm[0]
                        if crl <= 0.0:
                            continue
                        w = (s + 1.0) / (2.0 * np.pi) * np.exp(s * np.log(crl)) * row_omega[i]
                        a0 += pixels[i, j, 0] * w
                        a1 += pixels[i, j, 1] * w
                        a2 += pixels[i, j, 2] * w
                        continue
                    sz = dx * nx + dy * ny + dz * nz
                    if sz <= 0.0:
                        continue
                    sx = dx * tx + dy * ty + dz * tz
                    sy = dx * bx + dy * by + dz * bz
                    brdf_eval(model, prm, data, sx, sy, sz, lvx, lvy, lvz, f)
                    w = sz * row_omega[i]
                    a0 += pixels[i, j, 0] * f[0] * w
                    a1 += pixels[i, j, 1] * f[1] * w
                    a2 += pixels[i, j, 2] * f[2] * w
            out[k, t, 0], out[k, t, 1], out[k, t, 2] = a0, a1, a2


def angular_reflection_maps(pixels, rb: ReflectionBRDF, R, views, eps: float = 0.05):
    """Reflected radiance ``(K, N, 3)`` at texel directions ``R (N, 3)`` for ``K`` world views.

    ``pixels``: lat-long ``(H, 2H, 3)`` radiance. ``eps``: the angular
    truncation of appendix D (0 for the full hemisphere). The ``phong-lobe``
    ignores the views (pass one).
    """
    if rb.kind == "tangent":
        raise ParameterError("the angular baseline covers surface and lobe BRDFs, not kajiya-kay")
    px = np.ascontiguousarray(pixels, dtype=np.float64)
    if px.ndim != 3 or px.shape[1] != 2 * px.shape[0] or px.shape[2] != 3:
        raise ParameterError("the angular baseline takes a lat-long (2:1) RGB map")
    H, W = px.shape[:2]
    row_omega = latlong_solid_angles(H, W)[:, 0].copy()
    phi = 2.0 * np.pi * (np.arange(W) + 0.5) / W
    R = np.ascontiguousarray(np.asarray(R, float).reshape(-1, 3))
    V = np.ascontiguousarray(np.asarray(views, float).reshape(-1, 3))
    V = V / np.linalg.norm(V, axis=1, keepdims=True)
    ct = truncation_angles(rb, eps)
    out = np.zeros((V.shape[0], R.shape[0], 3))
    run_blocks(_angular, R.shape[0], R.shape[0] * V.shape[0] * H * W * 1.0,
               1 if rb.kind == "lobe" else 0, rb.model_id, np.ascontiguousarray(rb.prm, float),
               rb.data, R, V, ct, px, row_omega, np.sin(phi), np.cos(phi), out)  # fmt: skip
    return out
