"""A shading pass as a GPU would run it: one shader on the preview sphere, timed per frame.

:func:`render_pass` draws any shader of the registry (:mod:`shbake.shading.shader`) on
the sphere of :func:`~shbake.preview.sphere.sphere_geometry` seen from +Z (view ``v = +Z``
at every pixel, longitude-line tangents for the fibre shaders). Each of the shader's
update regimes (:meth:`~shbake.shading.shader.Shader.modes`) is run once to compile (or
load from numba's cache) and warm up, then timed; the image is the first regime's. With
``source`` (the original :class:`~shbake.envmap.Environment`) it draws the shader's ground
truth instead (:func:`shbake.reference.truth.truth`), timed once. Nothing here knows an
asset kind: what a pass reads is the shader's.
"""

import time

import numpy as np

from shbake.preview.sphere import paint, sphere_geometry
from shbake.progress import NO_PROGRESS
from shbake.reference.truth import truth

VIEW = np.array([0.0, 0.0, 1.0])
"""The preview camera's view (toward the viewer, world): orthographic from +Z."""
TRUTH_CHUNKS = 32
"""Blocks of pixels a ground truth is integrated in (one progress step each)."""


def sphere_points(size: int, min_nv: float | None = None):
    """The sphere's covered pixels: normals ``(N, 3)``, tangents ``(N, 3)``, views ``(N, 3)``
    and the mask ``(size, size)``; ``min_nv``: keep pixels with ``n·v`` above it only (the
    disc's last ring is grazing)."""
    normals, tangents, mask = sphere_geometry(size)
    if min_nv is not None:
        mask = mask & (normals[..., 2] > min_nv)
    n = np.ascontiguousarray(normals[mask])
    return n, np.ascontiguousarray(tangents[mask]), np.broadcast_to(VIEW, n.shape), mask


def _timed(run) -> tuple[np.ndarray, dict]:
    t0 = time.perf_counter()
    out = run()
    dt = time.perf_counter() - t0
    return out, {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}


def render_pass(shader, size: int, material: dict | None = None, source=None,
                progress=NO_PROGRESS, **truth_settings) -> tuple[np.ndarray, dict]:  # fmt: skip
    """Draw ``shader`` with ``material`` on a ``size``² sphere; ``(image (size, size, 3),
    timing)``. Timing: ``seconds``/``fps`` of the first update regime, and ``modes`` (each
    regime's) when the shader has several. ``source``: draw its ground truth under that map
    instead (``truth_settings``: ``samples``, ``merl_path``, ``merl_sha256``), in
    :data:`TRUTH_CHUNKS` blocks of pixels counted on ``progress`` (each pixel's integral is
    its own: the same bits as one call)."""
    material = dict(material or {})
    n, t, v, mask = sphere_points(size, shader.min_nv)
    tangents = {"tangents": t} if shader.tangents else {}
    out = np.zeros((size, size, 3))
    if source is not None:

        def run():
            parts = []
            with progress.task("brute-force reference", total=len(n), unit="pixel") as advance:
                for block in np.array_split(np.arange(len(n)), min(TRUTH_CHUNKS, len(n))):
                    parts.append(truth(shader, source, n[block], v[block], t[block],
                                       **material, **truth_settings))  # fmt: skip
                    advance(len(block))
            return np.concatenate(parts)

        img, timing = _timed(run)
        paint(out, mask, img)
        return out, timing
    modes, timings, img = shader.modes(n, v, **tangents, **material), {}, None
    for name, run in modes.items():
        run()  # compile (or load from cache) and warm up; time the second frame
        result, timings[name] = _timed(run)
        img = result if img is None else img
    paint(out, mask, img)
    first = next(iter(timings.values()))
    return out, dict(first, modes=timings) if len(timings) > 1 else first
