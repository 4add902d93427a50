"""What each GLSL pass costs: frame time at 1920×1080, texture memory, fetches and ALU per pixel.

For one shared map (default forest) the assets of ``tests/system/test_webgl_shaders.py`` (same
settings) are exported with ``--to webgl`` and every pass is drawn in headless Chromium
(``tests/engines/harness.mjs``) into a 1920×1080 float32 target that the sphere fills (every
pixel runs the pass), ``--frames`` frames after a warm-up frame, each finished by a
1-pixel read-back. **The harness runs WebGL2 on SwiftShader: these are CPU-emulation
times** (on this machine's shared cores), for comparing passes with each other, not a
GPU's. The fixed Kautz modes are timed per frame with their per-pixel store reused (the
light, or the view, unchanged); the Kautz passes on a smaller frame (:data:`SMALL`).

Texture memory: the bytes of the export's float32 textures. Fetches and ALU per pixel are
counted from the GLSL's loops (:func:`counts`: ``texelFetch`` calls; ALU = scalar
arithmetic operations, ``sqrt``/``exp`` counted as one, per the shader's code path for an
interior pixel). Prints a Markdown table.

    .venv/bin/python bench/shader_cost.py [--map forest] [--frames 3]
"""

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the tests package (tests.helpers), as pytest sees it

from shbake.bakers.env_sh import bake_env_sh  # noqa: E402
from shbake.bakers.shrm import bake_shrm  # noqa: E402
from shbake.batch.brdf_table import bake_brdf_table  # noqa: E402
from shbake.batch.export import export_assets  # noqa: E402
from shbake.batch.probe_eval import bake_splitsum_file  # noqa: E402
from shbake.batch.probe_fit import fit_probes  # noqa: E402
from shbake.brdf.reflection import make_reflection_brdf  # noqa: E402
from shbake.envmap import load_environment  # noqa: E402
from shbake.format.asset import write_asset  # noqa: E402
from shbake.format.shrm import build_shrm_asset  # noqa: E402
from tests.engine_browser import EngineBrowser, chromium_or_reason  # noqa: E402
from tests.helpers import map_path  # noqa: E402
from tests.webgl_cases import FIT, GLOSSY, SHRMS, SPLIT, TABLES  # noqa: E402

WIDTH, HEIGHT = 1920, 1080
SMALL_PASSES = ("kautz", "kautz-fixed-light", "kautz-fixed-view")
SMALL = 20
"""The Kautz passes are timed on a 96×54 frame and scaled by its pixel count (400): their
per-pixel rotation blocks live in local arrays, which SwiftShader spills to memory (about
0.4 ms a pixel: a 1920×1080 frame would take ~13 minutes); the fixed modes' per-pixel
store (one draw per coefficient) is built in the warm-up frame, outside the timing."""


def sh_sum(lmax: int, sets: int = 1) -> tuple[int, int]:
    """``shbakeSHBlend``: fetches ``sets·n``; ALU: the recurrence (``a``, ``b``: 2 sqrt and
    ~10 operations per step with ``l > m``), 6 per ``m`` for ``(x + iy)^m``, and per
    coefficient the vMF ``exp`` and products (2) plus a blend of ``sets`` RGB fetches (3 each)."""
    n = (lmax + 1) ** 2
    return sets * n, 6 * lmax * (lmax + 1) + 6 * lmax + n * (2 + 3 * sets)


BILINEAR = (4, 40)
"""``shbakeBilinear``: 4 fetches; two axes (~6 operations each) and a 4-channel blend (~28)."""


def counts(pass_name: str, u: dict) -> tuple[int, int]:
    """``(texel fetches, ALU operations)`` per interior pixel of ``pass_name`` given the
    export's uniforms ``u`` (name → value); ~30 operations of sphere geometry included."""
    v = {k: x["value"] for k, x in u.items()}
    geometry = 30
    lights = 7 * v.get("uLightCount", 0)
    if pass_name == "irradiance":
        f, a = sh_sum(v["uIrradianceLmax"])
        return f, a + lights + geometry
    if pass_name == "tangent-sh":
        f, a = sh_sum(v["uTangentLmax"])
        return f, a + 2 * lights + geometry
    if pass_name == "tangent-matrix":
        return 0, 3 * 24 + 2 * lights + geometry
    if pass_name == "splitsum":
        return 2 * BILINEAR[0] + BILINEAR[0], 3 * BILINEAR[1] + 2 * 14 + 30 + geometry
    if pass_name == "shexp":  # Q at h_ρ and at ρ (the tail), the DFG at n·v and at 1
        fp, ap = sh_sum(v["uLmaxP"], 2)
        fq, aq = sh_sum(v["uLmaxQ"], 2)
        return fp + 2 * fq + 2 * BILINEAR[0], ap + 2 * aq + 2 * BILINEAR[1] + 50 + geometry
    if pass_name == "shrm":  # interior: 4 taps, each one texel's eq. 12 (an SH sum)
        f, a = sh_sum(v["uShrmP"])
        return 4 * f, 4 * (a + 20) + 30 + geometry
    n = (v["uKautzLmax"] + 1) ** 2
    lmax = v["uKautzLmax"]
    table = 4 * n, 4 * 3 * n + 12  # c(v): a 4-tap blend per coefficient
    if pass_name == "kautz":
        blocks = sum((2 * l + 1) ** 2 for l in range(2, lmax + 1))
        light = sum((2 * l + 1) ** 2 for l in range(lmax + 1))  # L read per block row
        return table[0] + light, table[1] + 30 * blocks + 3 * 2 * light + 3 * n + geometry
    if pass_name == "kautz-fixed-light":
        return table[0] + n, table[1] + 6 * n + geometry
    return 2 * n, 6 * n + geometry  # kautz-fixed-view: stored and L, one dot


def bake(name: str, d: Path) -> dict:
    """The assets of tests/system/test_webgl_shaders.py for map ``name``, exported: pass →
    folder."""
    env = load_environment(str(map_path(name)), quiet=True)
    asset, _ = bake_env_sh(env, lmax=4, irradiance_lmax=4, sun=True)
    h5 = {"env": d / "env.h5", "splitsum": d / "splitsum.h5", "shexp": d / f"{name}.h5"}
    write_asset(str(h5["env"]), asset)
    bake_splitsum_file(str(map_path(name)), str(h5["splitsum"]), SPLIT)
    fit_probes([str(map_path(name))], out_dir=str(d), config=FIT)
    folders = {}
    for key in ("env", "splitsum", "shexp"):
        export_assets([str(h5[key])], "webgl", str(d / f"{key}-webgl"))
        folders[key] = d / f"{key}-webgl"
    for kind, (model, params, orders) in SHRMS.items():
        path = d / f"shrm-{kind}.h5"
        write_asset(str(path), build_shrm_asset(
            bake_shrm(env, make_reflection_brdf(model, params), **orders), env.meta))  # fmt: skip
        export_assets([str(path)], "webgl", str(d / f"shrm-{kind}-webgl"))
        folders[f"shrm {model}"] = d / f"shrm-{kind}-webgl"
    for model, params in TABLES.items():
        path = d / f"{model}.h5"
        bake_brdf_table(model, str(path), params, lmax=4, size=(16, 16), samples=64)
        export_assets([str(path)], "webgl", str(d / f"{model}-webgl"), env_path=str(h5["env"]))
        folders[f"kautz {model}"] = d / f"{model}-webgl"
    return folders


def texture_bytes(folder: Path, manifest: dict) -> int:
    return sum(os.path.getsize(folder / t["file"]) for t in manifest["textures"].values())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", default="forest")
    ap.add_argument("--frames", type=int, default=2)
    args = ap.parse_args()
    reason = chromium_or_reason()
    if reason:
        sys.exit(f"bench/shader_cost.py: {reason}")
    with tempfile.TemporaryDirectory() as tmp:
        folders = bake(args.map, Path(tmp))
        browser = EngineBrowser(tmp)
        r, f0 = GLOSSY[2]
        rows = []
        try:
            for label, folder in folders.items():
                manifest = json.loads((folder / "shbake.json").read_text())
                for p in manifest["passes"]:
                    w, h = (
                        (WIDTH // SMALL, HEIGHT // SMALL) if p in SMALL_PASSES else (WIDTH, HEIGHT)
                    )
                    job = {"name": p, "pass": p, "alpha": r * r, "f0": [f0] * 3, "reuse": True}
                    ms = browser.call("webgl.html", {
                        "dir": browser.url(str(folder)) + "/", "jobs": [job],
                        "timing": args.frames, "width": w, "height": h,
                    })["result"]["ms"][p]  # fmt: skip
                    scale = (WIDTH * HEIGHT) / (w * h)
                    note = f"timed at {w}×{h}, × {scale:.0f}" if scale > 1 else ""
                    fetches, alu = counts(p, manifest["uniforms"])
                    mib = texture_bytes(folder, manifest) / 2**20
                    rows.append((label, p, ms * scale, mib, fetches, alu, note))
        finally:
            browser.close()
    print(f"| asset ({args.map}) | pass | SwiftShader ms/frame 1920×1080 (CPU emulation) "
          "| texture MiB | fetches/pixel | ALU/pixel | note |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for label, p, ms, mib, fetches, alu, note in rows:
        print(f"| {label} | {p} | {ms:.0f} | {mib:.3f} | {fetches} | {alu} | {note} |")


if __name__ == "__main__":
    main()
