"""Brute-force shading of the BRDFs an SHRM bakes (Ramamoorthi & Hanrahan 2002), per
reparameterisation (:data:`shbake.brdf.reflection.REPARAMETERISATIONS`).

Over every texel of the original map (exact cell solid angles, SPEC §3), for unit world
``normals`` (and fibre ``tangents``) seen from one world ``view``:

- ``surface``: ``Σ L(ω) f(ω, v) max(0, n·ω) Ω`` with the :mod:`shbake.brdf` model in the
  frame of :func:`shbake.brdf.sampling.tangent_frame`
  (:func:`shbake.reference.brdf_shading.brute_force_shading`);
- ``lobe``: the radially symmetric Phong lobe, ``Σ L(ω) (s+1)/(2π) max(0, R·ω)^s Ω`` with
  ``R = 2(n·v)n − v`` (RH02 §6.3);
- ``tangent``: Kajiya–Kay about the tangent ``T``,
  ``Σ L(ω) (k_d sin θ_i / π + k_s (p+2)/(2π) max(0, sin θ_i sin θ_o − cos θ_i cos θ_o)^p) Ω``
  with ``cos θ_i = T·ω``, ``cos θ_o = T·v``.

Independent of the SH machinery: the references the ``shrm`` preview pass and
:class:`shbake.evaluation.shrm.ShrmCheck` measure a baked SHRM against.
"""

import numpy as np

from shbake.brdf.model import make_brdf
from shbake.brdf.sampling import tangent_frame
from shbake.errors import ParameterError
from shbake.reference.brdf_shading import brute_force_shading

CHUNK = 64
"""Shading points per vectorised block of the lobe and tangent sums."""


def brute_force_reflection(
    dirs,
    omega,
    radiance,
    kind: str,
    model: str,
    params: dict,
    normals,
    view,
    tangents=None,
    source: str = "",
    source_sha256: str | None = None,
) -> np.ndarray:
    """Outgoing radiance ``(N, 3)`` of the BRDF ``model`` (``params``; ``source``: MERL file,
    whose bytes must hash to ``source_sha256`` when given: :func:`~shbake.brdf.model.make_brdf`)
    reparameterised as ``kind``, at ``normals (N, 3)`` (``tangents`` for the tangent kind)
    seen from the unit world ``view (3,)``, summed over the texels ``dirs``, ``omega``,
    ``radiance`` (``Environment.samples()``, world frame)."""
    view = np.asarray(view, dtype=float)
    if kind == "surface":
        brdf = make_brdf(model, source or None, source_sha256, **params)
        frames = np.array([np.array([*tangent_frame(*x), x]) for x in normals])
        return brute_force_shading(dirs, omega, radiance, frames, frames @ view, brdf)
    out = np.zeros((len(normals if kind == "lobe" else tangents), 3))
    if kind == "lobe":
        s = float(params["s"])
        r = 2.0 * (normals @ view)[:, None] * normals - view
        for i in range(0, len(r), CHUNK):
            lobe = (s + 1) / (2 * np.pi) * np.clip(r[i : i + CHUNK] @ dirs.T, 0, None) ** s
            out[i : i + CHUNK] = (lobe * omega) @ radiance
        return out
    if kind == "tangent":
        kd, ks, p = (np.asarray(params[k], float) for k in ("kd", "ks", "p"))
        co = tangents @ view
        so = np.sqrt(np.maximum(0.0, 1.0 - co * co))
        for i in range(0, len(tangents), CHUNK):
            ci = tangents[i : i + CHUNK] @ dirs.T
            si = np.sqrt(np.maximum(0.0, 1.0 - ci * ci))
            cos_r = si * so[i : i + CHUNK, None] - ci * co[i : i + CHUNK, None]
            spec = np.clip(cos_r, 0, None) ** p
            for c in range(3):
                f = kd[c] * si / np.pi + ks[c] * (p + 2) / (2 * np.pi) * spec
                out[i : i + CHUNK, c] = (f * omega) @ radiance[:, c]
        return out
    raise ParameterError(f"unknown SHRM kind {kind!r}")
