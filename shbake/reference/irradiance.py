"""Irradiance and tangent irradiance by direct quadrature over every texel.

``E(n) = Σ_p L_p max(0, n·ω_p) Ω_p`` and
``E_t(t) = (1/π²) Σ_p L_p sqrt(1 - (t·ω_p)²) Ω_p`` with the texel-centre
directions ``ω_p`` and exact cell solid angles ``Ω_p`` of SPEC §3 — no SH
anywhere. Cost ``O(texels × query directions)``; converges at second order
in the texel size (shown in ``tests/reference/test_irradiance.py``).
"""

import numpy as np

from shbake.jit import jit, run_blocks

INV_PI2 = 1.0 / (np.pi * np.pi)


@jit
def _brute_force(dirs, lw, queries, tangent, out, b0, b1):
    """Check-free kernel: ``lw`` is radiance × solid angle ``(N, 3)``, queries unit ``(M, 3)``."""
    n = dirs.shape[0]
    for q in range(b0, b1):
        qx, qy, qz = queries[q, 0], queries[q, 1], queries[q, 2]
        r = 0.0
        g = 0.0
        b = 0.0
        for p in range(n):
            c = qx * dirs[p, 0] + qy * dirs[p, 1] + qz * dirs[p, 2]
            if tangent:
                k = np.sqrt(max(0.0, 1.0 - c * c))
            else:
                k = c if c > 0.0 else 0.0
            if k != 0.0:
                r += k * lw[p, 0]
                g += k * lw[p, 1]
                b += k * lw[p, 2]
        if tangent:
            r *= INV_PI2
            g *= INV_PI2
            b *= INV_PI2
        out[q, 0] = r
        out[q, 1] = g
        out[q, 2] = b


def _prepare(dirs, solid_angles, radiance):
    lw = (
        np.asarray(radiance, dtype=np.float64) * np.asarray(solid_angles, dtype=np.float64)[:, None]
    )
    keep = np.any(lw != 0.0, axis=1)
    return np.ascontiguousarray(dirs[keep], dtype=np.float64), np.ascontiguousarray(lw[keep])


def brute_force_irradiance(dirs, solid_angles, radiance, normals, tangent: bool = False):
    """Lambert (or, with ``tangent=True``, Kajiya–Kay) irradiance at ``normals``.

    Parameters
    ----------
    dirs : (N, 3) texel directions; solid_angles : (N,) sr; radiance : (N, 3).
    normals : (..., 3) unit query directions (normals, or tangents).

    Returns
    -------
    (..., 3) irradiance (radiance × sr; tangent irradiance is dimensionless ×
    radiance, ``E ≡ 1`` in a unit white dome).
    """
    d, lw = _prepare(dirs, solid_angles, radiance)
    q = np.asarray(normals, dtype=np.float64)
    flat = np.ascontiguousarray(q.reshape(-1, 3))
    out = np.empty((flat.shape[0], 3))
    run_blocks(_brute_force, flat.shape[0], flat.shape[0] * d.shape[0] * 10.0,
               d, lw, flat, tangent, out)  # fmt: skip
    return out.reshape(q.shape[:-1] + (3,))
