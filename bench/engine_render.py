"""Rendered engine exports on the six shared maps: the figures of docs/BENCHMARKS.md.

For each map: an env_sh asset (lmax 2), its exports at the chains of the tests
(:data:`tests.engine_cases.THREE_CUBES`, ``filament_cubes``, ``BABYLON_CUBES``, the
settings docs/EXPORTS.md recommends for glossy work: three.js ``threejs`` +
``threejs-pmrem``; Babylon.js ``babylon`` as ``.env`` and ``.gltf``; Filament
``filament``), rendered by the engines in headless Chromium (tests/engines/harness.mjs)
exactly as ``tests/system/test_engine_render.py`` does, and compared with the brute-force
references of that module: the diffuse max relative error against shbake's asset; the
median and 95th-percentile luminance relative error of each glossy sphere; the byte size
of each export. Prints Markdown tables.

    .venv/bin/python bench/engine_render.py [--maps city forest ...]

Needs ``npm ci --prefix tests/engines`` and Debian's ``chromium`` (``make test`` installs both).
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the tests package (tests.helpers), as pytest sees it

from shbake.bakers.env_sh import bake_env_sh  # noqa: E402
from shbake.batch.export import export_assets  # noqa: E402
from shbake.envmap import load_environment  # noqa: E402
from shbake.format.asset import write_asset  # noqa: E402
from shbake.format.exports.source import load_source  # noqa: E402
from tests.engine_browser import EngineBrowser, chromium_or_reason  # noqa: E402
from tests.engine_cases import (  # noqa: E402
    BABYLON_CUBES,
    FOV_DEG,
    GLOSSY,
    LAMBERT,
    SIZE,
    THREE_CUBES,
    VIEWS,
    babylon_expected,
    chain_sizes,
    diffuse_error,
    export_recording,
    filament_cubes,
    filament_expected,
    glossy_errors,
    pick_pixels,
    render_babylon,
    render_filament,
    render_three_glossy,
    sphere_materials,
    three_expected,
    white_env,
    white_environment,
    white_ktx1,
)
from tests.helpers import SHARED_MAPS, map_path  # noqa: E402


def sizes(files) -> int:
    return sum(os.path.getsize(f) for f in files)


def map_rows(browser, name: str, d: Path) -> dict:
    """Per engine: diffuse max error, glossy (median, p95) per material, export bytes."""
    path = str(map_path(name))
    env = load_environment(path, quiet=True)
    asset, _ = bake_env_sh(env, lmax=2, provenance={"input_abspath": path})
    h5 = str(d / f"{name}.h5")
    write_asset(h5, asset)
    src = load_source(h5)
    rows = {}
    # three.js: LightProbe JSON (diffuse) + PMREM KTX2 (glossy)
    probe = export_assets([h5], "threejs", str(d / f"{name}.json"))[0]
    pmrem, _ = export_recording(h5, "threejs-pmrem", str(d / f"{name}_pmrem.ktx2"), **THREE_CUBES)
    r = browser.render("three.html", VIEWS, SIZE, FOV_DEG, probe=browser.url(probe),
                       materials=[LAMBERT])  # fmt: skip
    white = white_environment(d, chain_sizes(THREE_CUBES))
    renders = render_three_glossy(browser, pmrem[0], white)
    rows["three.js r187"] = {
        "diffuse": diffuse_error(r, src, clamped=False),
        "glossy": glossy_errors(
            three_expected(env, renders, pick_pixels(renders["env"]["normal"]))
        ),
        "bytes": {".json": sizes([probe]), "_pmrem.ktx2": sizes(pmrem)},
    }
    # Filament: its own chain (seven levels, ten on studio: filament_cubes)
    cubes = filament_cubes(name)
    fil, _ = export_recording(h5, "filament", str(d / f"{name}_sh.txt"), **cubes)
    ibl = next(f for f in fil if f.endswith("_ibl.ktx"))
    env_r = render_filament(browser, d, [LAMBERT, *sphere_materials()], ibl)
    unit = white_ktx1(d, chain_sizes(cubes))
    white_r = render_filament(browser, d, sphere_materials(), unit)
    rows["Filament 1.53.4"] = {
        "diffuse": diffuse_error(env_r, src),
        "glossy": glossy_errors(
            filament_expected(env, env_r, white_r, pick_pixels(env_r["normal"]))
        ),
        "bytes": {"_sh.txt + _ibl.ktx + _skybox.ktx": sizes(fil)},
    }
    # Babylon.js: .env and .gltf from one chain
    benv, bchain = export_recording(h5, "babylon", str(d / f"{name}.env"), **BABYLON_CUBES)
    bgltf, _ = export_recording(h5, "babylon", str(d / f"{name}.gltf"), chain=bchain,
                                **BABYLON_CUBES)  # fmt: skip
    white_b = render_babylon(browser, sphere_materials(), env=white_env(d, BABYLON_CUBES["size"]))
    for label, kw, files in (
        (".env", {"env": benv[0]}, benv),
        (".gltf", {"gltf": bgltf[0]}, bgltf),
    ):
        rb = render_babylon(browser, [LAMBERT, *sphere_materials()], **kw)
        rows[f"Babylon.js 9.31 ({label})"] = {
            "diffuse": diffuse_error(rb, src),
            "glossy": glossy_errors(
                babylon_expected(env, src, rb, white_b, pick_pixels(rb["normal"]))
            ),
            "bytes": {label + (" + PNGs" if label == ".gltf" else ""): sizes(files)},
        }
    return rows


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
            rows = {}
            for m in args.maps:
                d = Path(tmp) / m
                d.mkdir()
                rows[m] = map_rows(browser, m, d)
                print(f"{m} done", file=sys.stderr, flush=True)
        finally:
            browser.close()
    names = [g[0] for g in GLOSSY]
    print(f"{browser.chromium}, SwiftShader, {SIZE}² float render target, 3 views\n")
    for engine in next(iter(rows.values())):
        print(f"\n{engine}\n")
        print("| map | diffuse max | " + " | ".join(f"{k} med / p95" for k in names) + " | bytes |")
        print("|---" * (len(names) + 3) + "|")
        for m, per in rows.items():
            row = per[engine]
            cells = [f"{row['glossy'][k][0]:.1%} / {row['glossy'][k][1]:.1%}" for k in names]
            size = ", ".join(f"{k} {v}" for k, v in row["bytes"].items())
            print(f"| {m} | {row['diffuse']:.1e} | " + " | ".join(cells) + f" | {size} |")


if __name__ == "__main__":
    main()
