"""Read shbake's KTX2 exports with libktx itself (pyktx), outside the test suite.

Issue 14 asks that the KTX2 files load with libktx. libktx has no wheel and
no Debian package (pyktx on PyPI is a 25 kB source package that links
against an installed libktx), so ``make test`` reads the files with
ktx-parse, the parser three.js vendors (tests/format/exports/test_ktx2.py). This script
is the libktx check, run by hand where a libktx build exists:

    # once: libktx and pyktx from a KTX-Software checkout (v4.4 or later)
    cmake -G Ninja -S KTX-Software -B build -DCMAKE_BUILD_TYPE=Release \\
        -DKTX_FEATURE_TESTS=OFF -DKTX_FEATURE_TOOLS=OFF -DBUILD_SHARED_LIBS=ON
    ninja -C build ktx
    python3.11 -m venv ktxvenv && ktxvenv/bin/pip install cffi==1.17.1
    (cd KTX-Software/interface/python_binding && \\
     LIBKTX_INCLUDE_DIR=../../lib/include DFDUTILS_INCLUDE_DIR=../../external/dfdutils \\
     LIBKTX_LIB_DIR=$PWD/../../../build/Release ../../../ktxvenv/bin/python buildscript.py)
    ninja -C build ktxtools   # optional: the `ktx` tool, for `ktx validate`
    # then
    PYKTX_PYTHON=ktxvenv/bin/python KTX_TOOL=build/Release/ktx \\
    PYKTX_PATH=KTX-Software/interface/python_binding .venv/bin/python bench/ktx2_libktx.py

It exports ``esplanade.exr`` to ``ktx2`` (16² cube chain, z-up, 20° turn,
plus the DFG table), loads both files with ``KtxTexture2.create_from_named_file``
in a child process (the interpreter that has pyktx) and checks, from what
libktx reports: the header (VkFormat, cube map, faces, levels, sizes), the
key/value data, each level's per-face image through ``image_offset`` (libktx's
own layout), level 0 against the mirror cube map computed here
independently, and the DFG table; and the Filament export's KTX1 IBL and
skybox through ``KtxTexture1``; with ``KTX_TOOL``, ``ktx validate`` (the
KTX 2.0 conformance checker) on both files. Prints a Markdown summary; exits 1 on a
mismatch.
"""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MAP = ROOT.parent / "shared" / "hdri" / "esplanade.exr"

READER = r"""
import json, sys
import numpy as np
from pyktx.ktx_texture1 import KtxTexture1
from pyktx.ktx_texture2 import KtxTexture2
from pyktx.ktx_texture_create_flag_bits import KtxTextureCreateFlagBits
from pyktx.native import lib
out = {}
for path in sys.argv[1:]:
    if path.endswith(".ktx"):
        t = KtxTexture1.create_from_named_file(path, KtxTextureCreateFlagBits.LOAD_IMAGE_DATA_BIT)
        kv = {k: v.rstrip(b"\0").decode() for k, v in t.kv_data.copy().items()}
        out[path] = {
            "gl_internalformat": lib.PY_ktxTexture1_get_glInternalformat(t._ptr),
            "is_cubemap": bool(t.is_cubemap), "num_faces": t.num_faces,
            "num_levels": t.num_levels, "base_width": t.base_width, "kv": kv,
            "level0": [t.data()[t.image_offset(0, 0, f):][:t.image_size(0)].hex()
                       for f in range(t.num_faces)],
        }
        continue
    t = KtxTexture2.create_from_named_file(path)
    data = t.data()
    levels = []
    for lv in range(t.num_levels):
        faces = []
        for f in range(t.num_faces):
            off = t.image_offset(lv, 0, f)
            n = t.image_size(lv)
            faces.append(data[off:off + n].hex())
        levels.append(faces)
    kv = {k: v.rstrip(b"\0").decode() for k, v in t.kv_data.copy().items()}
    out[path] = {
        "vk_format": int(t.vk_format), "is_cubemap": bool(t.is_cubemap),
        "num_faces": t.num_faces, "num_levels": t.num_levels,
        "base_width": t.base_width, "base_height": t.base_height,
        "supercompression": int(t.supercompression_scheme),
        "kv": kv, "levels": levels,
    }
json.dump(out, sys.stdout)
"""


def main() -> int:
    from shbake.bakers.cube_prefilter import downsample_cube, mirror_cube
    from shbake.bakers.dfg import dfg_table
    from shbake.bakers.env_sh import bake_env_sh
    from shbake.batch.export import export_assets
    from shbake.envmap.environment import load_environment
    from shbake.format.asset import write_asset
    from shbake.format.exports.source import frame_matrix

    python = os.environ.get("PYKTX_PYTHON")
    if not python:
        print("set PYKTX_PYTHON to an interpreter with pyktx (see the docstring)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as d:
        env = load_environment(str(MAP), quiet=True)
        asset, _ = bake_env_sh(env, lmax=2, provenance={"input_abspath": str(MAP)})
        write_asset(os.path.join(d, "e.h5"), asset)
        cube, dfg = export_assets(
            [os.path.join(d, "e.h5")],
            "ktx2",
            os.path.join(d, "e.ktx2"),
            frame="z-up",
            rotate_deg=20.0,
            size=16,
            floor=1,
            samples=32,
        )[:2]
        ibl, sky = sorted(
            f
            for f in export_assets(
                [os.path.join(d, "e.h5")], "filament", os.path.join(d, "f_sh.txt"), size=16, floor=1
            )
            if f.endswith(".ktx")
        )
        child_env = dict(os.environ)
        if os.environ.get("PYKTX_PATH"):
            child_env["PYTHONPATH"] = os.environ["PYKTX_PATH"]
        got = json.loads(
            subprocess.run(
                [python, "-c", READER, cube, dfg, ibl, sky],
                check=True,
                capture_output=True,
                text=True,
                env=child_env,
            ).stdout
        )
        c, t, fi, fs = got[cube], got[dfg], got[ibl], got[sky]
        want0 = downsample_cube(mirror_cube(env, 32, rotation=frame_matrix("z-up", 20.0)))
        lv0 = np.stack(
            [np.frombuffer(bytes.fromhex(h), "<f2").reshape(16, 16, 4) for h in c["levels"][0]]
        ).astype(np.float64)
        err0 = float(np.max(np.abs(lv0[..., :3] - want0) / np.maximum(np.abs(want0), 1e-6)))
        sizes = [len(bytes.fromhex(f[0])) for f in c["levels"]]
        table = np.frombuffer(bytes.fromhex(t["levels"][0][0]), "<f2").reshape(
            t["base_height"], t["base_width"], 2
        )
        dfg_err = float(np.max(np.abs(table - np.transpose(dfg_table(), (1, 0, 2)))))
        checks = {
            "cube: VkFormat 97 (R16G16B16A16_SFLOAT), cube map, 6 faces": (
                c["vk_format"] == 97 and c["is_cubemap"] and c["num_faces"] == 6
            ),
            "cube: 16×16, 5 levels (16…1), no supercompression": (
                (c["base_width"], c["base_height"], c["num_levels"], c["supercompression"])
                == (16, 16, 5, 0)
            ),
            "cube: per-face image bytes 16²·8, 8²·8, …, 1·8": (
                sizes == [n * n * 8 for n in (16, 8, 4, 2, 1)]
            ),
            "cube: key/value shbake.roughness starts at 0 (mirror)": (
                json.loads(c["kv"]["shbake.roughness"])[0] == 0.0
            ),
            f"cube: level 0 = mirror cube map, max relative error {err0:.1e} (half floats)": (
                err0 < 1e-3
            ),
            "cube: alpha 1 everywhere": bool(np.all(lv0[..., 3] == 1.0)),
            f"DFG: VkFormat 83 (R16G16_SFLOAT), table max abs error {dfg_err:.1e}": (
                t["vk_format"] == 83 and not t["is_cubemap"] and dfg_err < 1e-3
            ),
        }
        sky0 = np.stack(
            [np.frombuffer(bytes.fromhex(h), "<u4").reshape(16, 16) for h in fs["level0"]]
        )  # R11F_G11F_B10F texels: any bit pattern is finite but exponent 31
        checks["Filament (KTX1): IBL and skybox load, R11F_G11F_B10F cube maps, `sh` key"] = all(
            f["gl_internalformat"] == 0x8C3A
            and f["is_cubemap"]
            and f["num_faces"] == 6
            and len(f["kv"]["sh"].split()) == 27
            for f in (fi, fs)
        )
        checks[f"Filament (KTX1): IBL levels {fi['num_levels']} (16…1), skybox 1"] = (
            fi["num_levels"] == 5 and fs["num_levels"] == 1 and fi["base_width"] == 16
        )
        checks["Filament (KTX1): skybox level 0 = the IBL's level 0 (mirror)"] = bool(
            fi["level0"] == fs["level0"]
            and not np.any(((sky0 >> 6) & 31) == 31)
            and not np.any(((sky0 >> 17) & 31) == 31)
            and not np.any((sky0 >> 27) == 31)
        )
        tool = os.environ.get("KTX_TOOL")
        for path, name in ((cube, "cube"), (dfg, "DFG")) if tool else ():
            r = subprocess.run([tool, "validate", path], capture_output=True, text=True)
            errors = [ln for ln in r.stdout.splitlines() if ln.startswith("error-")]
            checks[f"{name}: `ktx validate` exit {r.returncode}, errors {errors or 'none'}"] = (
                r.returncode == 0
            )
    print("| libktx check (pyktx `KtxTexture1`/`KtxTexture2`, `ktx validate`) | holds |")
    print("|---|---|")
    for name, ok in checks.items():
        print(f"| {name} | {'yes' if ok else 'NO'} |")
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
