"""Rendered engine exports on the six shared maps: the figures of docs/BENCHMARKS.md.

For each map: an env_sh asset (lmax 2), its exports at the targets' defaults, rendered
by the engine in headless Chromium (tests/engines/harness.mjs) exactly as
``tests/test_engine_render.py`` does, and compared with the brute-force references of
that module (median and 95th-percentile luminance relative error per roughness; the
diffuse max relative error against shbake's asset evaluation); the byte size of each
export. Prints a Markdown table.

    .venv/bin/python bench/engine_render.py [--maps city forest ...]

Needs ``npm ci --prefix tests/engines`` and Debian's ``chromium`` (``make test`` installs both).
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import numpy as np  # noqa: E402
from engine_browser import EngineBrowser, chromium_or_reason, inner_pixels  # noqa: E402
from helpers import SHARED_MAPS, map_path  # noqa: E402
from test_engine_render import (  # noqa: E402
    FOV_DEG,
    GLOSSY,
    SIZE,
    VIEWS,
    glossy_errors,
    pick_pixels,
    render_three_glossy,
    three_expected,
    white_environment,
)

from shbake.bakers.env_sh import bake_env_sh  # noqa: E402
from shbake.batch.export import export_assets  # noqa: E402
from shbake.envmap import load_environment  # noqa: E402
from shbake.format.asset import write_asset  # noqa: E402
from shbake.format.exports import target_module  # noqa: E402
from shbake.format.exports.source import load_source, shbake_irradiance  # noqa: E402


def three_row(browser, name: str, d: Path) -> dict:
    path = str(map_path(name))
    env = load_environment(path, quiet=True)
    asset, _ = bake_env_sh(env, lmax=2, provenance={"input_abspath": path})
    h5 = str(d / f"{name}.h5")
    write_asset(h5, asset)
    probe = export_assets([h5], "threejs", str(d / f"{name}.json"))[0]
    pmrem = export_assets([h5], "threejs-pmrem", str(d / f"{name}_pmrem.ktx2"))[0]
    cubes = target_module("threejs-pmrem").CUBES
    n_levels = int(np.log2(cubes["size"] // cubes["floor"])) + 1
    white = white_environment(d, [cubes["size"] >> i for i in range(n_levels)])
    lambert = [{"name": "lambert", "kind": "lambert", "color": [1.0, 1.0, 1.0]}]
    r = browser.render("three.html", VIEWS, SIZE, FOV_DEG, probe=browser.url(probe),
                       materials=lambert)  # fmt: skip
    inner = inner_pixels(r["normal"])
    n = r["normal"][..., :3][inner]
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    want = shbake_irradiance(load_source(h5), n) / np.pi
    got = r["radiance"]["lambert"][..., :3][inner]
    diffuse = float((np.abs(got - want).max(-1) / want.max(-1)).max())
    renders = render_three_glossy(browser, pmrem, white)
    errors = glossy_errors(three_expected(env, renders, pick_pixels(renders["env"]["normal"])))
    return {
        "diffuse": diffuse,
        "glossy": errors,
        "bytes": {"json": os.path.getsize(probe), "pmrem": os.path.getsize(pmrem)},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="+", default=list(SHARED_MAPS))
    args = ap.parse_args()
    reason = chromium_or_reason()
    if reason:
        sys.exit(f"engine_render: {reason}")
    with tempfile.TemporaryDirectory() as tmp:
        browser = EngineBrowser(tmp)
        try:
            rows = {m: three_row(browser, m, Path(tmp)) for m in args.maps}
        finally:
            browser.close()
    names = [g[0] for g in GLOSSY]
    print(f"three.js r187 ({browser.chromium}, SwiftShader), {SIZE}² render target, 3 views\n")
    print("| map | diffuse max | " + " | ".join(f"{k} med / p95" for k in names)
          + " | .json bytes | _pmrem.ktx2 bytes |")  # fmt: skip
    print("|---" * (len(names) + 4) + "|")
    for m, row in rows.items():
        cells = [f"{row['glossy'][k][0]:.1%} / {row['glossy'][k][1]:.1%}" for k in names]
        print(f"| {m} | {row['diffuse']:.1e} | " + " | ".join(cells)
              + f" | {row['bytes']['json']} | {row['bytes']['pmrem']} |")  # fmt: skip


if __name__ == "__main__":
    main()
