"""The ``shrm`` preview pass: a sphere shaded from an ``shrm`` asset, timed per frame.

Orthographic camera on +Z (view ``V = +Z``, :mod:`shbake.preview.sphere`).
Each frame runs what an engine would (§7.5): eq. 12 builds the dynamic
reflection cube map for ``V`` (:func:`shbake.shading.shrm.reflection_cube`),
then every pixel reads it at ``R = 2(n·V)n − V`` (tangent kind: at the
longitude-line tangent) by seam-correct bilinear cube lookup. The timing is
the best of a few frames after a warm-up, reported for eq. 12 alone and for
the whole frame.

``reference``: the same BRDF integrated against the original map by brute
force (:func:`shbake.reference.reflection.brute_force_reflection`).
"""

import json
import time

import numpy as np

from shbake.errors import ParameterError
from shbake.format.shrm import SHRM
from shbake.preview.sphere import paint, sphere_geometry
from shbake.reference.reflection import brute_force_reflection
from shbake.shading.shrm import reflection_cube, shade

VIEW = np.array([0.0, 0.0, 1.0])


def _best(f, frames):
    f()
    best = np.inf
    for _ in range(frames):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def render_shrm(shrm: SHRM, size: int = 192, frames: int = 5):
    """The ``shrm`` pass: image ``(size, size, 3)`` and timing.

    Timing keys: ``seconds``/``fps`` (whole frame: eq. 12 + lookup),
    ``eq12_seconds``/``eq12_fps`` (the reflection-cube update alone).
    """
    normals, tangents, mask = sphere_geometry(size)
    kind = shrm.shading_kind
    n, t = normals[mask], tangents[mask]
    out = np.zeros((size, size, 3))

    def update():
        return reflection_cube(shrm.cube, VIEW, kind)

    def frame():
        cube = update()
        paint(out, mask, shade(cube, n, VIEW, t if kind == "tangent" else None))

    t_eq12 = _best(update, frames)
    t_frame = _best(frame, frames)
    return out, {
        "seconds": t_frame,
        "fps": 1.0 / t_frame,
        "eq12_seconds": t_eq12,
        "eq12_fps": 1.0 / t_eq12,
        "face_size": shrm.face_size,
        "F": shrm.F,
        "P": shrm.P,
    }


def render_reference(shrm: SHRM, source, size: int = 192):
    """Brute-force reference of the asset's BRDF over ``source`` (an Environment)."""
    normals, tangents, mask = sphere_geometry(size)
    n, tg = normals[mask], tangents[mask]
    dirs, om, rad = source.samples()
    a = shrm.attrs
    params = a["brdf_parameters"]
    params = params if isinstance(params, dict) else json.loads(params)
    out = np.zeros((size, size, 3))
    t0 = time.perf_counter()
    paint(out, mask, brute_force_reflection(dirs, om, rad, shrm.kind, a["brdf_model"], params,
                                            n, VIEW, tg, a.get("brdf_source") or ""))  # fmt: skip
    dt = time.perf_counter() - t0
    return out, {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}


def preview_shrm(asset, pass_name, size: int, diff: bool, source):
    """The preview of an ``shrm`` asset: ``(image, reference or None, summary, settings)``.

    Passes ``shrm`` (default) and ``reference``; ``diff`` adds the reference to ``shrm``.
    ``source``: the original Environment (needed by ``reference`` and ``diff``).
    """
    from shbake.format.shrm import shrm_from_asset

    pass_name = pass_name or "shrm"
    if pass_name not in ("shrm", "reference") or (diff and pass_name == "reference"):
        raise ParameterError("an shrm asset has passes shrm and reference (--diff: shrm)")
    shrm = shrm_from_asset(asset)
    if pass_name == "reference":
        img, timing = render_reference(shrm, source, size)
    else:
        img, timing = render_shrm(shrm, size)
    summary = {"pass": pass_name, "size": size, **timing}
    reference = None
    if diff:
        reference, ref_timing = render_reference(shrm, source, size)
        summary["reference_seconds"] = ref_timing["seconds"]
    settings = (f"{shrm.attrs['brdf_model']} F {shrm.F} P {shrm.P}, face {shrm.face_size}, "
                f"size {size}")  # fmt: skip
    if pass_name == "shrm":
        settings += f", eq. 12 {timing['eq12_fps']:.0f}/s"
    return img, reference, summary, settings
