"""The error an engine's level-of-detail rule alone gives: an ideal chain read as the engine does.

three.js r187 and Filament 1.53 both read a prefiltered cube at ``lod = (n − 1) r (2 − r)``
(three ``roughnessToMip``, ``envmap_common_pars_fragment``; Filament
``perceptualRoughnessToLod``, ``light_indirect.fs``), blending the two levels around it
linearly. Neither draws a mirror: three raises ``r`` to 0.045 plus its geometry roughness
(``getGeometryRoughness``, ``lights_physical_fragment``: the largest component of
``max(|∂x n|, |∂y n|)`` of the view-space normal); Filament widens ``α²`` by gltfio's specular
anti-aliasing (``min(2 · 0.15 (|∂x n|² + |∂y n|²), 0.2)``, ``base.mat.in``) and floors ``r`` at
0.089. A "mirror" sphere drawn at 128² pixels therefore reads ``lod ≈ 0.7`` of a seven-level
chain in three (30 % of the mirror level, 70 % of level 1) and ``lod ≈ 1.3`` in Filament
(levels 1 and 2). More levels bring the levels' roughnesses closer together and lower
this floor; the texels of the rough levels (not modelled here) set the other side of
that trade.

This script replaces every level by its exact brute-force value (level 0: the map read
bilinearly; level ``i``: ``P(R', α_i)``, :func:`shbake.reference.prefiltered.reference_radiance`,
no texels, no sampling) and blends them as the engine does; the error of that blend against
brute-force ``P(R', α(r))`` is what no chain shbake could write removes. Same camera, sphere
pixels, pixel sample and error definition as ``tests/system/test_engine_render.py`` (the
sphere is ray-traced here; derivatives are taken on 2×2 pixel quads,
:func:`tests.engine_browser.quad_derivatives`, the rule the rendered-engine tests check).

    .venv/bin/python bench/engine_lod_floor.py [--engine three|filament|babylon] [--maps city …]

Prints one Markdown row per map: median / 95th percentile of the luminance relative error
for the mirror (r 0), r 0.3 and r 0.6 metal spheres.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the tests package, as pytest sees it

from shbake.envmap import load_environment  # noqa: E402
from shbake.format.exports.cube_chain import BABYLON_MIN_ALPHA, roughness_of_level  # noqa: E402
from shbake.reference.irradiance import brute_force_irradiance  # noqa: E402
from shbake.reference.prefiltered import reference_radiance  # noqa: E402
from tests.engine_browser import (  # noqa: E402
    latlong_bilinear,
    pixel_rays,
    quad_derivatives,
    reflect,
)
from tests.engine_cases import (  # noqa: E402
    BABYLON_CUBES,
    FILAMENT_CUBES,
    FILAMENT_MIN_ROUGHNESS,
    FILAMENT_SPECULAR_AA,
    FOV_DEG,
    REFERENCE_PIXELS,
    SIZE,
    THREE_CUBES,
    THREE_MIN_ROUGHNESS,
    VIEWS,
    chain_sizes,
    luminance_error,
)

MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")


def sphere_pixels(view) -> tuple[np.ndarray, ...]:
    """Rays, unit normals, three's geometry roughness and Filament's anti-aliasing kernel
    (added to ``α²``) at the unit sphere's inner pixels."""
    rays = pixel_rays(view, SIZE, FOV_DEG)
    eye = np.asarray(view.eye, dtype=np.float64)
    b = rays @ eye
    disc = b * b - (eye @ eye - 1.0)
    hit = disc > 0
    n = eye + (-b - np.sqrt(np.where(hit, disc, 0.0)))[..., None] * rays
    back = eye / np.linalg.norm(eye)
    right = np.cross(view.up, back)
    right /= np.linalg.norm(right)
    dx, dy = quad_derivatives((n @ np.stack([right, np.cross(back, right), back]).T)[None])
    g = np.maximum(np.abs(dx), np.abs(dy)).max(-1)[0]
    variance, threshold = FILAMENT_SPECULAR_AA
    kernel = np.minimum(2.0 * variance * ((dx * dx).sum(-1) + (dy * dy).sum(-1)), threshold)[0]
    inner = hit.copy()
    for axis in (0, 1):
        for step in (1, -1):
            inner &= np.roll(hit, step, axis)
    return rays[inner], n[inner], g[inner], kernel[inner]


CHAINS = {"three": THREE_CUBES, "filament": FILAMENT_CUBES, "babylon": BABYLON_CUBES}
"""Each engine's chain in the tests (its level count is ``--levels``' default)."""


def lookups(engine: str, r_material: float, refl, n, g, kernel, levels: int):
    """``(lookup directions, α of the reference, lod read)`` of a sphere of perceptual
    roughness ``r_material`` as ``engine`` draws it."""
    if engine == "babylon":  # pbrIBLFunctions getLodFromAlphaG; MINIMUMVARIANCE; no R' mix
        size = BABYLON_CUBES["size"]
        alpha = np.full(len(refl), r_material**2 + BABYLON_MIN_ALPHA)
        lod = (levels - 1) / np.log2(size) * np.log2(size * alpha)
        return refl, alpha, np.clip(lod, 0.0, levels - 1.0)
    if engine == "three":
        r = np.minimum(np.maximum(r_material, THREE_MIN_ROUGHNESS) + g, 1.0)
    else:
        filtered = np.minimum(r_material**4 + kernel, 1.0) ** 0.25
        r = np.maximum(filtered, FILAMENT_MIN_ROUGHNESS)
    look = refl + (n - refl) * (r**4)[:, None]  # three r⁴, Filament α²: the same
    look /= np.linalg.norm(look, axis=-1, keepdims=True)
    return look, r**2, np.minimum((levels - 1) * r * (2.0 - r), levels - 1.0)


def ideal_blend(env, look, lod, levels: int, mapping: str, size: int) -> np.ndarray:
    """Exact levels (the chain's roughness per level, ``mapping``) blended linearly at ``lod``."""
    i0 = np.minimum(np.floor(lod).astype(int), levels - 2)
    f = (lod - i0)[:, None]
    out = np.empty((len(lod), 3))
    for i in np.unique(i0):
        m = i0 == i
        below, above = (roughness_of_level(k, levels, mapping, size) for k in (i, i + 1))
        if below == 0.0:
            lo = latlong_bilinear(env.pixels, look[m])
        else:
            lo = reference_radiance(env, look[m], below**2)
        out[m] = (1.0 - f[m]) * lo + f[m] * reference_radiance(env, look[m], above**2)
    return out


def map_row(engine: str, name: str, levels: int) -> str:
    env = load_environment(str(ROOT.parent / "shared" / "hdri" / f"{name}.exr"), quiet=True)
    rng = np.random.default_rng(0)
    px = [sphere_pixels(v) for v in VIEWS]
    rays, n, g, kernel = (np.concatenate(a) for a in zip(*px, strict=True))
    keep = np.sort(rng.choice(len(rays), min(REFERENCE_PIXELS, len(rays)), replace=False))
    rays, n, g, kernel = rays[keep], n[keep], g[keep], kernel[keep]
    refl = reflect(rays, n)
    mapping, size = ("babylon", BABYLON_CUBES["size"]) if engine == "babylon" else ("filament", 0)
    e_over_pi = brute_force_irradiance(*env.samples(), n) / np.pi
    cells = []
    for r_material in (0.0, 0.3, 0.6):
        look, alpha, lod = lookups(engine, r_material, refl, n, g, kernel, levels)
        if r_material == 0.0 and engine == "babylon":  # its mirror reads level 0: the map
            want = latlong_bilinear(env.pixels, look)
        else:
            want = reference_radiance(env, look, alpha)
        got = ideal_blend(env, look, lod, levels, mapping, size)
        if engine == "babylon":  # mix(prefiltered, E/π, α): pbrBlockReflection, as the tests
            got, want = (
                (1.0 - alpha)[:, None] * v + (alpha[:, None] * e_over_pi) for v in (got, want)
            )
        e = luminance_error(got, want)
        cells.append(f"{np.median(e):.1%} / {np.percentile(e, 95):.1%}")
    return f"| {name} | " + " | ".join(cells) + " |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="three", choices=("three", "filament", "babylon"))
    ap.add_argument("--maps", nargs="+", default=list(MAPS), choices=MAPS)
    ap.add_argument(
        "--levels",
        type=int,
        help="chain levels (default: the tests' chain: three 8, Filament 7, Babylon 9)",
    )
    args = ap.parse_args()
    args.levels = args.levels or len(chain_sizes(CHAINS[args.engine]))
    print(f"{args.engine} lod rule, ideal {args.levels}-level chain, {SIZE}² pixels, "
          f"{len(VIEWS)} views")  # fmt: skip
    print("\n| map | r 0 (mirror) | r 0.3 | r 0.6 |\n|---|---|---|---|")
    for name in args.maps:
        print(map_row(args.engine, name, args.levels), flush=True)


if __name__ == "__main__":
    main()
