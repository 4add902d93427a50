"""Brute-force shading with any BRDF: the ``reference`` of the ``kautz`` pass.

``Q(p) = Σ_texels L(ω) f(R_p ω, R_p v') max(0, (R_p ω)_z) Ω(ω)`` over every
texel of the original map (exact cell solid angles, SPEC §3), with ``R_p``
the world → local frame of pixel ``p``. Independent of the SH machinery.
"""

import numpy as np

from shbake.brdf.dispatch import brdf_eval
from shbake.brdf.model import BRDF
from shbake.jit import jit, run_blocks


@jit
def _shade(dirs, omega, radiance, frames, views, model, prm, data, out, b0, b1):
    for p in range(b0, b1):
        f = np.empty(3)
        R = frames[p]
        vx, vy, vz = views[p, 0], views[p, 1], views[p, 2]
        a0 = a1 = a2 = 0.0
        for t in range(dirs.shape[0]):
            dx, dy, dz = dirs[t, 0], dirs[t, 1], dirs[t, 2]
            sz = R[2, 0] * dx + R[2, 1] * dy + R[2, 2] * dz
            if sz <= 0.0:
                continue
            sx = R[0, 0] * dx + R[0, 1] * dy + R[0, 2] * dz
            sy = R[1, 0] * dx + R[1, 1] * dy + R[1, 2] * dz
            brdf_eval(model, prm, data, sx, sy, sz, vx, vy, vz, f)
            w = sz * omega[t]
            a0 += radiance[t, 0] * f[0] * w
            a1 += radiance[t, 1] * f[1] * w
            a2 += radiance[t, 2] * f[2] * w
        out[p, 0], out[p, 1], out[p, 2] = a0, a1, a2


def brute_force_shading(dirs, omega, radiance, frames, views_local, brdf: BRDF) -> np.ndarray:
    """Outgoing radiance ``(P, 3)`` for ``P`` shading points.

    Parameters
    ----------
    dirs, omega, radiance : the map's texels (``Environment.samples()``).
    frames : (P, 3, 3) world → local rotations (rows: tangent, bitangent, normal).
    views_local : (P, 3) unit view directions in the local frames, ``z > 0``.
    """
    out = np.zeros((len(frames), 3))
    run_blocks(
        _shade,
        len(frames),
        len(frames) * len(dirs) * 60.0,
        np.ascontiguousarray(dirs, dtype=float),
        np.ascontiguousarray(omega, dtype=float),
        np.ascontiguousarray(radiance, dtype=float),
        np.ascontiguousarray(frames, dtype=float),
        np.ascontiguousarray(views_local, dtype=float),
        brdf.spec.model_id,
        brdf.packed,
        brdf.data,
        out,
    )
    return out
