"""Relative RMS error of the kautz pass vs brute force: AS (24,8), three maps, lmax 2–8.

Shared by tests/shading/test_brdf_table.py (asserts the figures) and bench/brdf_table.py
(writes them to docs/BENCHMARKS.md). Settings: env lighting projected at
lmax 8 (no sun extraction), 64² tables at 1024 samples, 48² sphere.
"""

from shbake.bakers.env_sh import bake_env_sh
from shbake.brdf import make_brdf
from shbake.brdf.tabulate import tabulate
from shbake.envmap import load_environment
from shbake.evaluation.metrics import relative_rms_error
from shbake.format.brdf_table import BRDFTable
from shbake.preview.passes import render_pass
from shbake.shading.shader import shader

MAPS = ("esplanade", "forest", "studio")
LMAXES = (2, 4, 6, 8)
SIZE = 48


def kautz_errors(map_path) -> dict:
    brdf = make_brdf("ashikhmin-shirley", nu=24, nv=8)
    env = load_environment(str(map_path), quiet=True)
    asset, _ = bake_env_sh(env, lmax=8)
    ref = None
    out = {}
    for lmax in LMAXES:
        coeffs, _ = tabulate(brdf, lmax, (64, 64), samples=1024)
        table = BRDFTable(coeffs, lmax, brdf.name, {"nu": 24, "nv": 8}, "", {})
        kautz = shader(asset, "kautz", table=table)
        if ref is None:  # the table's BRDF by brute force (independent of lmax)
            ref, _ = render_pass(kautz, SIZE, source=env)
        img, _ = render_pass(kautz, SIZE)
        out[lmax] = relative_rms_error(img, ref)
    return out
