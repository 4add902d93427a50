"""Shading passes as a GPU would run them, one pixel at a time (numba, parallel).

``irradiance``: white Lambert sphere, radiance ``E(n)/π`` with
``E(n) = Σ_i y_i(n) E_i`` from ``/irradiance/sh`` plus the directional light
of ``/sun`` if present. ``tangent``: Kajiya–Kay diffuse sphere with
longitude-line tangents, ``E(t) = t̃ᵀ M t̃`` from ``/tangent_irradiance/matrix``
(Mehta eq. 23) plus the sun's ``sqrt(1 − (t·s)²)/π²`` term. ``kautz``: a
BRDF table shaded under the asset's lighting (:mod:`shbake.preview.kautz`).
The reference passes compute the same quantities by brute force over the
original map; ``reference`` with a table integrates the table's BRDF.
"""

import time

import numba
import numpy as np

from shbake.format.asset import Asset
from shbake.jit import pjit
from shbake.preview.sphere import sphere_geometry
from shbake.sh.basis import recurrence_tables, sh_eval_into

INV_PI = 1.0 / np.pi
INV_PI2 = 1.0 / (np.pi * np.pi)

PASSES = ("irradiance", "tangent", "kautz", "reference", "reference-tangent")


@pjit
def _irradiance_pass(normals, mask, coeffs, lmax, qmm, a, b, sun_dir, sun_energy, out):
    h, w = mask.shape
    n = coeffs.shape[0]
    for i in numba.prange(h):
        y = np.empty(n)
        for j in range(w):
            if not mask[i, j]:
                continue
            nx, ny, nz = normals[i, j, 0], normals[i, j, 1], normals[i, j, 2]
            sh_eval_into(nx, ny, nz, lmax, qmm, a, b, y)
            c = nx * sun_dir[0] + ny * sun_dir[1] + nz * sun_dir[2]
            k = c if c > 0.0 else 0.0
            for ch in range(3):
                e = k * sun_energy[ch]
                for q in range(n):
                    e += y[q] * coeffs[q, ch]
                out[i, j, ch] = e * INV_PI


@pjit
def _tangent_pass(tangents, mask, M, sun_dir, sun_energy, out):
    h, w = mask.shape
    for i in numba.prange(h):
        for j in range(w):
            if not mask[i, j]:
                continue
            t = (tangents[i, j, 0], tangents[i, j, 1], tangents[i, j, 2], 1.0)
            c = t[0] * sun_dir[0] + t[1] * sun_dir[1] + t[2] * sun_dir[2]
            k = np.sqrt(max(0.0, 1.0 - c * c)) * INV_PI2
            for ch in range(3):
                e = k * sun_energy[ch]
                for r in range(4):
                    for s in range(4):
                        e += t[r] * M[ch, r, s] * t[s]
                out[i, j, ch] = e


def _sun(asset: Asset):
    if "/sun/direction" in asset:
        return asset["/sun/direction"], asset["/sun/radiance"] * float(asset["/sun/solid_angle"])
    return np.array([0.0, 0.0, 1.0]), np.zeros(3)


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
        from shbake.preview.kautz import render_kautz

        img, modes = render_kautz(asset, table, size)
        return img, {**modes["full"], "modes": modes}
    if name == "reference" and brdf is not None:
        from shbake.preview.kautz import shading_frames
        from shbake.reference.brdf_shading import brute_force_shading

        frames, views, mask = shading_frames(size)
        dirs, omega, radiance = source.samples()
        out = np.zeros((size, size, 3))
        t0 = time.perf_counter()
        out[mask] = brute_force_shading(dirs, omega, radiance, frames, views, brdf)
        dt = time.perf_counter() - t0
        return out, {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}
    normals, tangents, mask = sphere_geometry(size)
    out = np.zeros((size, size, 3))
    sun_dir, sun_energy = _sun(asset)
    if name == "irradiance":
        coeffs = np.ascontiguousarray(asset["/irradiance/sh"])
        lmax = int(round(np.sqrt(coeffs.shape[0]))) - 1
        qmm, a, b = recurrence_tables(lmax)

        def run():
            _irradiance_pass(normals, mask, coeffs, lmax, qmm, a, b, sun_dir, sun_energy, out)

    elif name == "tangent":
        M = np.ascontiguousarray(asset["/tangent_irradiance/matrix"])

        def run():
            _tangent_pass(tangents, mask, M, sun_dir, sun_energy, out)

    elif name in ("reference", "reference-tangent"):
        from shbake.reference.irradiance import brute_force_irradiance

        tangent = name == "reference-tangent"
        dirs, omega, radiance = source.samples()
        query = tangents if tangent else normals

        def run():
            e = brute_force_irradiance(dirs, omega, radiance, query[mask], tangent=tangent)
            out[mask] = e if tangent else e * INV_PI

    else:
        raise ValueError(f"unknown pass {name!r}")
    if not name.startswith("reference"):
        run()  # compile (or load from cache) and warm up; time the second frame
    t0 = time.perf_counter()
    run()
    dt = time.perf_counter() - t0
    return out, {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}
