"""Irradiance and tangent irradiance vs brute force on the six shared maps.

For lmax 2 and 8, with and without --extract-sun: mean and max luminance
relative error over 2048 spherical-Fibonacci directions (SPEC §5 brute
force with exact texel solid angles). Prints a Markdown table and, with
--json, the figures the tests assert (tests/accuracy/test_shared_maps.py).

    .venv/bin/python bench/irradiance_accuracy.py
"""

import argparse
import json
from pathlib import Path

from shbake.bakers.env_sh import bake_env_sh
from shbake.envmap import load_environment
from shbake.evaluation.env_sh import brute_force_reference, irradiance_errors

MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
HDRI = Path(__file__).resolve().parent.parent.parent / "shared" / "hdri"


def measure(name: str) -> dict:
    env = load_environment(str(HDRI / f"{name}.exr"), quiet=True)
    ref = brute_force_reference(env)
    out = {}
    for lmax in (2, 8):
        for sun in (False, True):
            asset, summary = bake_env_sh(env, lmax=lmax, irradiance_lmax=lmax, sun=sun)
            key = f"lmax{lmax}{'+sun' if sun else ''}"
            out[key] = irradiance_errors(asset, env, ref)
            if sun:
                out[key]["sun_extracted"] = "/sun/direction" in asset
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    results = {m: measure(m) for m in MAPS}
    if args.json:
        print(json.dumps(results, indent=1, sort_keys=True))
        return
    print("| map | setting | irradiance mean | irradiance max | tangent mean | tangent max |")
    print("|---|---|---|---|---|---|")
    for m, r in results.items():
        for k, v in r.items():
            sun = (
                ""
                if "sun_extracted" not in v
                else (" (light found)" if v["sun_extracted"] else " (no light found)")
            )
            print(
                f"| {m} | {k}{sun} | {v['irradiance']['mean']:.2%} | {v['irradiance']['max']:.2%}"
                f" | {v['tangent_irradiance']['mean']:.3%} | {v['tangent_irradiance']['max']:.3%} |"
            )


if __name__ == "__main__":
    main()
