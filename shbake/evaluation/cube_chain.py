"""The error of a GGX prefiltered cube chain as an engine reads it (``export --report``).

An engine shading a surface of perceptual roughness ``r`` reads the chain at one
level of detail, ``lod = ℓ(r)`` (:func:`shbake.format.exports.cube_chain.level_of_roughness`:
three.js and Filament ``(n − 1) r (2 − r)``, Babylon.js ``s log2(N0 (α + α_min))``,
glTF-IBL-Sampler's ``(n − 1) r``), trilinearly: a seam-correct bilinear fetch of each of the
two levels around ``lod``, blended linearly by its fraction (``textureLod`` with
``LINEAR_MIPMAP_LINEAR``, :func:`shbake.format.exports.cube_chain.read_chain`). That read at the
reflection direction (``N = V = R``), against brute-force ``P(R, α)``
(:func:`shbake.reference.prefiltered.reference_radiance`) of the
map the chain holds, is the chain's error: its texels, its samples and the engine's blend
of two differently blurred levels (the last no chain removes; ``bench/engine_lod_floor.py``)
together. It is measured on the chain as baked, before its file's encoding (float16,
or 8-bit RGBD for glTF and ``.env``).

Measured at :data:`REPORT_DIRECTIONS` Fibonacci directions for each roughness of
:data:`REPORT_ROUGHNESS`: the median and 95th percentile of the pointwise relative error
of luminance (:func:`shbake.evaluation.metrics.relative_errors`), the measure of
``tests/system/test_engine_render.py`` and docs/BENCHMARKS.md's engine tables, where the
engines' own renders of the same chains are compared with brute force.
"""

import numpy as np

from shbake.conventions import REC709_LUMINANCE, ggx_alpha
from shbake.envmap.environment import Environment
from shbake.evaluation.metrics import relative_errors
from shbake.format.exports.cube_chain import BABYLON_MIN_ALPHA, level_of_roughness, read_chain
from shbake.reference.prefiltered import reference_radiance
from shbake.sh.point_sets import fibonacci_sphere

REPORT_ROUGHNESS = (0.1, 0.3, 0.6)
"""Perceptual roughness the report reads a chain at. 0.1 stands for a mirror: no engine
draws one (three.js raises ``r`` to 0.045 plus its geometry roughness, about 0.02–0.1 on a
sphere 128 pixels across; Filament floors ``r`` at 0.089), and below ``α`` 0.01 a
512-wide map's texels are wider than the lobe."""

REPORT_DIRECTIONS = 2048
"""Fibonacci directions each roughness is measured at (as the irradiance report's)."""

WARNING_P95 = 0.15
"""95th-percentile error above which ``export --report`` warns (issue 29's engine bound)."""


def chain_errors(
    env: Environment,
    levels: list,
    mapping: str,
    rotation: np.ndarray | None = None,
    roughness=REPORT_ROUGHNESS,
    n_dirs: int = REPORT_DIRECTIONS,
) -> list[dict]:
    """The error of a chain read as its ``mapping``'s engines read it (module docstring).

    Parameters
    ----------
    env : Environment
        The map the chain holds (world frame; the export's map less its lights).
    levels : list of ``(6, n, n, 3)`` arrays
        The chain, level 0 first (:func:`shbake.bakers.cube_chain.prefilter_chain`).
    mapping : one of :data:`shbake.format.exports.cube_chain.LOD_MAPPINGS`
        The engine's roughness → lod rule.
    rotation : 3×3, optional
        Target ← world rotation the chain was baked with.
    roughness : perceptual roughness values in (0, 1]

    Returns
    -------
    list of dict
        Per roughness ``{"roughness", "lod", "median", "p95"}`` (relative errors of
        luminance, fractions).
    """
    world = fibonacci_sphere(int(n_dirs))
    target = world if rotation is None else world @ np.asarray(rotation, dtype=np.float64).T
    size0 = levels[0].shape[1]
    out = []
    for r in roughness:
        lod = level_of_roughness(float(r), len(levels), mapping, size0)
        alpha = ggx_alpha(float(r)) + (BABYLON_MIN_ALPHA if mapping == "babylon" else 0.0)
        got = read_chain(levels, target, lod) @ REC709_LUMINANCE
        want = reference_radiance(env, world, alpha) @ REC709_LUMINANCE
        err = relative_errors(got, want)
        out.append({"roughness": float(r), "lod": float(lod), "median": float(np.median(err)),
                    "p95": float(np.percentile(err, 95))})  # fmt: skip
    return out


def chain_warnings(errors: list[dict]) -> list[str]:
    """What :func:`chain_errors` should make a user act on: the roughness values read above
    :data:`WARNING_P95` at the 95th percentile, and what lowers them."""
    high = [e for e in errors if e["p95"] > WARNING_P95]
    if not high:
        return []
    where = ", ".join(f"{e['p95']:.1%} at r {e['roughness']:g}" for e in high)
    return [f"the glossy chain as the engine reads it is {where} from brute force (p95, above "
            f"{WARNING_P95:.0%}): more levels (a lower --floor) bring the engine's blend of two "
            "levels nearer the lobe at low roughness, a larger --size gives the rough levels "
            "finer faces; docs/EXPORTS.md lists each engine's measured chain"]  # fmt: skip


__all__ = [
    "REPORT_DIRECTIONS",
    "REPORT_ROUGHNESS",
    "WARNING_P95",
    "chain_errors",
    "chain_warnings",
]
