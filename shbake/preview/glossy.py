"""Glossy probe passes: spheres shaded from ``shexp_probe`` and ``splitsum_probe`` assets.

The preview sphere (orthographic camera on +Z, view ``v = +Z``,
:mod:`shbake.preview.sphere`) made of GGX of width ``α`` (SPEC §1; the CLI
also takes perceptual ``r``, ``α = r²``) and Schlick reflectance ``F0``
(1: chrome, 0.04: dielectric):

- ``shexp``: ``E = F0 E0 + (1 − F0) E0 A1/A0`` with ``E0 = P Q`` from the
  asset's ``/p``, ``/q``, ``/knots`` and ``/dfg`` (Silvennoinen et al. 2025,
  eq. 5, 11, 15);
- ``splitsum``: prefiltered radiance at the mirror direction times
  ``F0 A0 + (1 − F0) A1`` from ``/levels``, ``/level_alpha`` and ``/dfg``
  (Karis 2013);
- ``reference``: the ground truth ``F0 E0 + (1 − F0) E1`` integrated over the
  original map (:func:`shbake.reference.ggx.ggx_integrals`).

The probe passes read nothing but the asset's arrays. ``α`` outside the
probe's range, and probes of the old perceptual convention, are refused
(:func:`check_probe_alpha`).
"""

import time

import numpy as np

from shbake.errors import ParameterError
from shbake.format.asset import Asset
from shbake.format.probe import check_probe_alpha
from shbake.preview.sphere import paint, sphere_geometry
from shbake.reference.ggx import ggx_integrals
from shbake.shading.shexp import evaluate_shexp
from shbake.shading.splitsum import evaluate_splitsum

GLOSSY_PASSES = ("shexp", "splitsum", "reference")
PASS_OF_KIND = {"shexp_probe": "shexp", "splitsum_probe": "splitsum"}


def _shade(asset: Asset, name, views, normals, alpha, f0, source, samples):
    if name == "reference":
        e0, e1 = ggx_integrals(source.pixels, views, normals, alpha, samples)
        return f0 * e0 + (1.0 - f0) * e1
    if name != PASS_OF_KIND.get(asset.kind):
        raise ParameterError(f"pass {name!r} needs a {name}_probe asset, got {asset.kind}")
    f0s = (f0,) * 3
    if name == "shexp":
        return evaluate_shexp(asset["/p"], asset["/q"], asset["/dfg"], views, normals,
                              alpha, f0s, asset["/knots"])  # fmt: skip
    levels = [asset[f"/levels/{k}"] for k in range(int(asset.attrs["levels"]))]
    return evaluate_splitsum(levels, asset["/level_alpha"], asset["/dfg"], views, normals,
                             alpha, f0s)  # fmt: skip


def render_glossy(
    asset: Asset, name: str, size: int, alpha: float, f0: float, source=None,
    samples: int = 4096,
) -> tuple[np.ndarray, dict]:  # fmt: skip
    """Render glossy pass ``name`` on a ``size``² sphere of GGX width ``alpha``;
    ``(image, timing)``.

    ``source``: the original :class:`~shbake.envmap.Environment` (``reference``
    only); ``samples``: its visible-normal samples per pixel.
    """
    if name not in GLOSSY_PASSES:
        raise ParameterError(f"unknown glossy pass {name!r}")
    if not 0.0 <= f0 <= 1.0:
        raise ParameterError(f"F0 must lie in [0, 1], got {f0:g}")
    alpha = check_probe_alpha(asset, alpha)
    normals, _, mask = sphere_geometry(size)
    # the disc's last ring is grazing (n·v → 0); shade pixels with n·v > 1e-3
    mask = mask & (normals[..., 2] > 1e-3)
    n = normals[mask]
    v = np.broadcast_to([0.0, 0.0, 1.0], n.shape)
    out = np.zeros((size, size, 3))
    args = (asset, name, v, n, alpha, f0, source, samples)
    if name != "reference":
        _shade(*args)  # compile (or load from cache) and warm up; time the second frame
    t0 = time.perf_counter()
    paint(out, mask, _shade(*args))
    dt = time.perf_counter() - t0
    return out, {"seconds": dt, "fps": 1.0 / dt if dt > 0 else float("inf")}
