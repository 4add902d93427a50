"""The error three.js's level-of-detail rule alone gives: an ideal chain read as three reads it.

three r187 reads a prefiltered cube at ``lod = (n − 1) r (2 − r)`` (``roughnessToMip``,
``envmap_common_pars_fragment``), blending the two levels around it linearly, with ``r``
the material's roughness raised to 0.045 plus the geometry roughness
(``getGeometryRoughness``, ``lights_physical_fragment``: the view-space normal's screen
derivatives). A "mirror" sphere drawn at 128² pixels therefore has ``r ≈ 0.06`` and reads
``lod ≈ 0.7``: 30 % of the mirror level and 70 % of level 1 (``r = 0.087``). This script
replaces every level by its exact brute-force value (level 0: the map read bilinearly; level
``i``: ``P(R', α_i)``, :func:`shbake.bakers.cube_prefilter.reference_radiance`, no texels, no
sampling) and blends them as three does; the error of that blend against brute-force
``P(R', α(r))`` is what no chain shbake could write removes. Same camera, sphere pixels,
pixel sample and error definition as ``tests/system/test_engine_render.py`` (the sphere is
ray-traced here; three's derivatives are taken on 2×2 pixel quads).

    .venv/bin/python bench/engine_lod_floor.py [--maps city forest ...] [--levels 7]

Prints one Markdown row per map: median / 95th percentile of the luminance relative error
for the mirror (r 0), r 0.3 and r 0.6 metal spheres.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the tests package, as pytest sees it

from shbake.bakers.cube_prefilter import reference_radiance, roughness_of_level  # noqa: E402
from shbake.envmap import load_environment  # noqa: E402
from tests.engine_browser import latlong_bilinear, pixel_rays, reflect  # noqa: E402
from tests.engine_cases import (  # noqa: E402
    FOV_DEG,
    REFERENCE_PIXELS,
    SIZE,
    THREE_MIN_ROUGHNESS,
    VIEWS,
    luminance_error,
)

MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")


def sphere_pixels(view) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rays, unit normals and three's geometry roughness of the unit sphere's inner pixels."""
    rays = pixel_rays(view, SIZE, FOV_DEG)
    eye = np.asarray(view.eye, dtype=np.float64)
    b = rays @ eye
    disc = b * b - (eye @ eye - 1.0)
    hit = disc > 0
    n = eye + (-b - np.sqrt(np.where(hit, disc, 0.0)))[..., None] * rays
    back = eye / np.linalg.norm(eye)
    right = np.cross(view.up, back)
    right /= np.linalg.norm(right)
    view_n = n @ np.stack([right, np.cross(back, right), back]).T
    quad = view_n.reshape(SIZE // 2, 2, SIZE // 2, 2, 3)
    dx = np.abs(quad[:, :, :, 1] - quad[:, :, :, 0])[:, :, :, None]  # per quad row
    dy = np.abs(quad[:, 1] - quad[:, 0])[:, None]  # per quad column
    g = np.maximum(dx, dy).max(-1).reshape(SIZE, SIZE)
    inner = hit.copy()
    for axis in (0, 1):
        for step in (1, -1):
            inner &= np.roll(hit, step, axis)
    return rays[inner], n[inner], g[inner]


def ideal_blend(env, look: np.ndarray, r: np.ndarray, levels: int) -> np.ndarray:
    """Exact levels blended linearly at three's lod for roughness ``r``."""
    lod = np.minimum((levels - 1) * r * (2.0 - r), levels - 1.0)
    i0 = np.minimum(np.floor(lod).astype(int), levels - 2)
    f = (lod - i0)[:, None]
    out = np.empty((len(r), 3))
    for i in np.unique(i0):
        m = i0 == i
        below, above = (roughness_of_level(k, levels, "filament") for k in (i, i + 1))
        if below == 0.0:
            lo = latlong_bilinear(env.pixels, look[m])
        else:
            lo = reference_radiance(env, look[m], below**2)
        out[m] = (1.0 - f[m]) * lo + f[m] * reference_radiance(env, look[m], above**2)
    return out


def map_row(name: str, levels: int) -> str:
    env = load_environment(str(ROOT.parent / "shared" / "hdri" / f"{name}.exr"), quiet=True)
    rng = np.random.default_rng(0)
    px = [sphere_pixels(v) for v in VIEWS]
    rays, n, g = (np.concatenate(a) for a in zip(*px, strict=True))
    keep = np.sort(rng.choice(len(rays), min(REFERENCE_PIXELS, len(rays)), replace=False))
    rays, n, g = rays[keep], n[keep], g[keep]
    refl = reflect(rays, n)
    cells = []
    for r_material in (0.0, 0.3, 0.6):
        r = np.minimum(np.maximum(r_material, THREE_MIN_ROUGHNESS) + g, 1.0)
        look = refl + (n - refl) * (r**4)[:, None]
        look /= np.linalg.norm(look, axis=-1, keepdims=True)
        e = luminance_error(ideal_blend(env, look, r, levels), reference_radiance(env, look, r**2))
        cells.append(f"{np.median(e):.1%} / {np.percentile(e, 95):.1%}")
    return f"| {name} | " + " | ".join(cells) + " |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", nargs="+", default=list(MAPS), choices=MAPS)
    ap.add_argument("--levels", type=int, default=7, help="chain levels (7: 256² to 4²)")
    args = ap.parse_args()
    print(f"three.js lod rule, ideal {args.levels}-level chain, {SIZE}² pixels, {len(VIEWS)} views")
    print("\n| map | r 0 (mirror) | r 0.3 | r 0.6 |\n|---|---|---|---|")
    for name in args.maps:
        print(map_row(name, args.levels), flush=True)


if __name__ == "__main__":
    main()
