"""The least error any prefiltered chain can have over an engine's roughness range: a bound.

three.js and Filament read a chain of ``n`` levels at ``lod = (n − 1) r (2 − r)`` and blend
the two levels around it linearly (``bench/engine_lod_floor.py``). Whatever the levels hold,
the value read along a direction ``d`` at ``lod`` is therefore ``Σ_k h_k(lod) v_k(d)``, with
``h_k`` the blend's hat weights and ``v_k(d)`` what level ``k`` gives at ``d``; every
roughness from the engine's floor up to ``--up-to`` is some material's, and each is expected
to give ``P(d, α(lod))`` (brute force, :func:`shbake.reference.prefiltered.reference_radiance`).
For each direction, a linear program (:func:`tests.engine_cases.blend_bound`) gives the
least largest relative error over that roughness range that *any* chain can have at ``d``:
levels free per direction (no texels, no bilinear coupling between directions), so every
chain shbake or anyone could write errs at least this much at ``d`` for some roughness in
the range. The lods are sampled 12 per level (a subset of the continuous range: the bound
stays a lower bound).

The directions are those the rendered-engine tests' mirror sphere shows
(``tests/system/test_engine_render.py``: same camera, pixels and sample). Prints a Markdown
row per map and level count: median, 90th and 95th percentile of the per-direction bound
and the share of directions where it exceeds 15 %. Where that share is above 5 %, no chain
can render every roughness in the range within 15 % at the 95th percentile of those
directions (one roughness alone may still be within: the bound is over the range).

    .venv/bin/python bench/engine_blend_floor.py [--engine filament|three] [--levels N]
        [--up-to 0.3] [--maps studio …]
"""

import argparse

import numpy as np
from engine_lod_floor import CHAINS, MAPS, ROOT, lookups, sphere_pixels

from shbake.envmap import load_environment
from tests.engine_browser import reflect
from tests.engine_cases import (
    FILAMENT_MIN_ROUGHNESS,
    P95_TOL,
    REFERENCE_PIXELS,
    THREE_MIN_ROUGHNESS,
    VIEWS,
    blend_bound,
    bound_lods,
    chain_sizes,
    prefiltered_luminance,
)


def mirror_directions(engine: str, levels: int) -> np.ndarray:
    """The look-up directions of the rendered-engine tests' mirror sphere (their pixel sample)."""
    rng = np.random.default_rng(0)
    px = [sphere_pixels(v) for v in VIEWS]
    rays, n, g, kernel = (np.concatenate(a) for a in zip(*px, strict=True))
    keep = np.sort(rng.choice(len(rays), min(REFERENCE_PIXELS, len(rays)), replace=False))
    rays, n, g, kernel = rays[keep], n[keep], g[keep], kernel[keep]
    return lookups(engine, 0.0, reflect(rays, n), n, g, kernel, levels)[0]


def map_row(engine: str, name: str, levels: int, up_to: float) -> str:
    env = load_environment(str(ROOT.parent / "shared" / "hdri" / f"{name}.exr"), quiet=True)
    floor = FILAMENT_MIN_ROUGHNESS if engine == "filament" else THREE_MIN_ROUGHNESS
    lods, knots = bound_lods(floor, levels, up_to)
    target = prefiltered_luminance(env, mirror_directions(engine, levels), lods, levels)
    bound = np.array([blend_bound(lods, knots, t) for t in target])
    q = np.percentile(bound, [50, 90, 95])
    return (f"| {name} | {levels} | {lods[0]:.2f}–{lods[-1]:.2f} | {q[0]:.1%} | {q[1]:.1%} | "
            f"{q[2]:.1%} | {np.mean(bound > P95_TOL):.1%} |")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="filament", choices=("filament", "three"))
    ap.add_argument("--maps", nargs="+", default=list(MAPS), choices=MAPS)
    ap.add_argument("--levels", type=int, nargs="+",
                    help="chain levels (default: the tests' chain)")  # fmt: skip
    ap.add_argument("--up-to", type=float, default=0.3,
                    help="the roughest material of the range (default 0.3)")  # fmt: skip
    args = ap.parse_args()
    counts = args.levels or [len(chain_sizes(CHAINS[args.engine]))]
    print(f"{args.engine}: per-direction bound over r from its floor to {args.up_to}, "
          f"the mirror sphere's directions ({len(VIEWS)} views)")  # fmt: skip
    print("\n| map | levels | lods | median | p90 | p95 | share > 15 % |")
    print("|---|---|---|---|---|---|---|")
    for name in args.maps:
        for levels in counts:
            print(map_row(args.engine, name, levels, args.up_to), flush=True)


if __name__ == "__main__":
    main()
