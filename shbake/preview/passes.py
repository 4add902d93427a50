"""Shading passes as a GPU would run them, one pixel at a time (numba, parallel).

``irradiance``: white Lambert sphere, radiance ``E(n)/π`` with
``E(n) = Σ_i y_i(n) E_i`` from ``/irradiance/sh`` plus the directional light
of ``/sun`` if present. ``tangent``: Kajiya–Kay diffuse sphere with
longitude-line tangents, ``E(t) = t̃ᵀ M t̃`` from ``/tangent_irradiance/matrix``
(Mehta eq. 23) plus the sun's ``sqrt(1 − (t·s)²)/π²`` term. ``kautz``: a
BRDF table shaded under the asset's lighting (:mod:`shbake.preview.kautz_table`).
Shading comes from :mod:`shbake.shading`.
The reference passes compute the same quantities by brute force over the
original map; ``reference`` with a table integrates the table's BRDF.
"""

import time

import numpy as np

from shbake.format.asset import Asset
from shbake.preview.sphere import paint, sphere_geometry
from shbake.shading.env_sh import irradiance, tangent_irradiance_matrix

INV_PI = 1.0 / np.pi

PASSES = ("irradiance", "tangent", "kautz", "reference", "reference-tangent")


def render_pass(
    asset: Asset, name: str, size: int = 256, source=None, table=None, brdf=None
) -> tuple[np.ndarray, dict]:
    """Render pass ``name`` of an ``env_sh`` asset on a ``size``² sphere.

    ``source`` is the original :class:`~shbake.envmap.Environment`, needed by
    the reference passes only; ``table`` a :class:`~shbake.brdf.table_asset.BRDFTable`
    for ``kautz``; ``brdf`` turns ``reference`` into the brute-force shading
    with that BRDF. Returns the linear image ``(size, size, 3)`` and timing
    ``{"seconds": …, "fps": …}`` (the kernel alone, after compilation; for
    ``kautz`` also ``"modes"``: full, fixed-light and fixed-view timings).
    """
    if name == "kautz":
        from shbake.preview.kautz_table import render_kautz

        img, modes = render_kautz(asset, table, size)
        return img, {**modes["full"], "modes": modes}
    if name == "reference" and brdf is not None:
        from shbake.preview.kautz_table import shading_frames
        from shbake.reference.brdf_shading import brute_force_shading

        frames, views, mask = shading_frames(size)
        dirs, omega, radiance = source.samples()
        out = np.zeros((size, size, 3))
        t0 = time.perf_counter()
        paint(out, mask, brute_force_shading(dirs, omega, radiance, frames, views, brdf))
        dt = time.perf_counter() - t0
        return out, {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}
    normals, tangents, mask = sphere_geometry(size)
    out = np.zeros((size, size, 3))
    if name == "irradiance":
        n = np.ascontiguousarray(normals[mask])

        def run():
            paint(out, mask, irradiance(asset, n), INV_PI)

    elif name == "tangent":
        t = np.ascontiguousarray(tangents[mask])

        def run():
            paint(out, mask, tangent_irradiance_matrix(asset, t))

    elif name in ("reference", "reference-tangent"):
        from shbake.reference.irradiance import brute_force_irradiance

        tangent = name == "reference-tangent"
        dirs, omega, radiance = source.samples()
        query = tangents if tangent else normals

        def run():
            e = brute_force_irradiance(dirs, omega, radiance, query[mask], tangent=tangent)
            paint(out, mask, e, 1.0 if tangent else INV_PI)

    else:
        raise ValueError(f"unknown pass {name!r}")
    if not name.startswith("reference"):
        run()  # compile (or load from cache) and warm up; time the second frame
    t0 = time.perf_counter()
    run()
    dt = time.perf_counter() - t0
    return out, {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}
