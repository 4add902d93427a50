"""The ``kautz`` preview pass: a BRDF table on the sphere (:mod:`shbake.shading.kautz_table`).

Per pixel ``p`` of the preview sphere (orthographic camera on +Z, view
``v' = +Z``): the local frame ``R_p`` has the normal as +Z and, as +X, the
brushing direction — world +Y projected on the tangent plane (the paper's
"constant vector projected to the tangent space"), so anisotropic lobes run
along the sphere's meridians. The full, fixed-light and fixed-view modes are
timed separately.
"""

import time

import numpy as np

from shbake.preview.sphere import paint, sphere_geometry
from shbake.sh.rotation import block_offsets
from shbake.shading.kautz_table import (
    dot_world,
    lighting_with_sun,
    lookup_dot,
    rotate_coeffs_to_world,
    rotate_lighting,
    shade_full,
)


def shading_frames(size: int):
    """World → local rotations ``(P, 3, 3)``, local views ``(P, 3)`` and the mask."""
    normals, tangents, mask = sphere_geometry(size)
    n, t = normals[mask], tangents[mask]
    b = np.cross(n, t)
    frames = np.stack([t, b, n], axis=1)
    views = frames @ np.array([0.0, 0.0, 1.0])
    views[:, 2] = np.maximum(views[:, 2], 0.0)
    return np.ascontiguousarray(frames), np.ascontiguousarray(views), mask


def render_kautz(env_asset, table, size: int = 192) -> tuple[np.ndarray, dict]:
    """Render the sphere; the image and per-mode (full, fixed_light, fixed_view) timings."""
    frames, views, mask = shading_frames(size)
    lmax = table.lmax
    L = lighting_with_sun(env_asset, lmax)
    coeffs = np.ascontiguousarray(table.coeffs)
    offsets = block_offsets(lmax)
    P, n = len(frames), L.shape[0]
    L_local = np.empty((P, n, 3))
    c_world = np.empty((P, n, 3))
    q = np.empty((P, 3))

    def full():
        shade_full(frames, views, coeffs, L, lmax, offsets, q)

    def fixed_light():
        lookup_dot(views, coeffs, L_local, q)

    def fixed_view():
        dot_world(c_world, L, q)

    timing = {}
    rotate_coeffs_to_world(frames, views, coeffs, lmax, offsets, c_world)
    rotate_lighting(frames, L, lmax, offsets, L_local)
    for name, run in (("fixed_view", fixed_view), ("fixed_light", fixed_light), ("full", full)):
        run()  # compile / warm
        t0 = time.perf_counter()
        run()
        dt = time.perf_counter() - t0
        timing[name] = {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}
    img = np.zeros((size, size, 3))
    paint(img, mask, q)
    return img, timing
