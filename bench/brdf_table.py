"""brdf-table speed/accuracy: converged AS table time, error vs lmax/resolution/samples.

Run: .venv/bin/python bench/brdf_table.py [--runs N]
(2 threads; writes bench/results/brdf_table.md)

The ``--tol`` row (issue 15) times the whole ``shbake brdf-table`` process and,
in the same run interleaved round by round, the nested refinement against the
previous method (Gauss–Legendre levels redone at every doubling, the tree at
:data:`PREVIOUS_TOL`) on the same table.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the tests package (tests.helpers), as pytest sees it

from timing import interleaved, machine, med, previous_module, ratio  # noqa: E402

from shbake.bakers.brdf_table_report import settings_report  # noqa: E402
from shbake.brdf import make_brdf  # noqa: E402
from shbake.brdf.tabulate import tabulate  # noqa: E402
from tests.helpers import map_path  # noqa: E402
from tests.kautz_accuracy import LMAXES, MAPS, kautz_errors  # noqa: E402

PREVIOUS_TOL = "4de1567"
"""The last tree whose ``--tol`` redid every Gauss–Legendre level (before the nested rules)."""
TOL_ARGS = ["ashikhmin-shirley", "-p", "nu=24", "-p", "nv=8", "--tol", "1e-4", "--size", "128",
            "--lmax", "4", "--reproducible", "-q"]  # fmt: skip


def tol_rows(runs: int) -> list[str]:
    """The issue-15 row: whole-process wall time and nested vs previous ``--tol`` refinement."""
    shbake = [sys.executable, "-c", "from shbake_cli.main import main; main()", "brdf-table"]
    out = os.path.join(tempfile.mkdtemp(), "t.h5")
    env = {**os.environ, "SHBAKE_THREADS": "2", "NUMBA_NUM_THREADS": "2"}

    def process():
        subprocess.run(shbake + TOL_ARGS + ["-o", out], check=True, env=env)

    b = make_brdf("ashikhmin-shirley", nu=24, nv=8)
    kw = dict(samples=None, tol=1e-4, max_samples=1 << 18)
    fns = {"process": process, "nested": lambda: tabulate(b, 4, (128, 128), **kw)}
    prev = previous_module("shbake/brdf/tabulate.py", "tabulate_previous", PREVIOUS_TOL)
    if prev is not None:
        fns["previous"] = lambda: prev.tabulate(b, 4, (128, 128), **kw)
    t = interleaved(fns, n=runs)
    _, conv = tabulate(b, 4, (128, 128), **kw)
    rows = [
        f"## `shbake brdf-table {' '.join(TOL_ARGS)} -o t.h5` (goal < 10 s wall on 2 cores)",
        "",
        f"{machine()}; 2 threads; median (min–max) of {runs} runs, wall seconds.",
        "",
        "| what | seconds | ratio previous ÷ nested | largest estimate | points per strategy |",
        "|---|---|---|---|---|",
        f"| whole process (CLI) | {med(t['process'], 1, '{:.2f}')} | | | |",
        f"| tabulate, nested rules | {med(t['nested'], 1, '{:.2f}')} | | {conv.error:.2e} | "
        f"{conv.view_samples[64:, 64:].sum() / 1e6:.1f} M |",
    ]
    if prev is not None:
        _, pc = prev.tabulate(b, 4, (128, 128), **kw)
        done = sum(h["samples"] * h["views"] for h in pc.history)  # every level after the first
        rows.append(
            f"| tabulate, previous ({PREVIOUS_TOL}) | {med(t['previous'], 1, '{:.2f}')} | "
            f"{ratio(t['previous'], t['nested'])} | {pc.error:.2e} | {done / 1e6:.1f} M |"
        )
    return rows + [""]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    os.environ.setdefault("SHBAKE_THREADS", "2")
    lines = ["# brdf-table benchmark (2 numba threads)", ""]
    tabulate(make_brdf("ashikhmin-shirley"), 4, (8, 8), samples=64)  # compile
    lines += tol_rows(args.runs)
    lines += [
        "## Converged 128×128×25 tables (--tol 1e-4, max 262144 samples)",
        "",
        "| BRDF | seconds | largest error estimate | texels above 1e-4 |",
        "|---|---|---|---|",
    ]
    for nu, nv in ((12, 4), (24, 8), (48, 16)):
        b = make_brdf("ashikhmin-shirley", nu=nu, nv=nv)
        t0 = time.perf_counter()
        _, conv = tabulate(b, 4, (128, 128), samples=None, tol=1e-4, max_samples=1 << 18)
        dt = time.perf_counter() - t0
        bad = int((conv.view_errors > 1e-4).sum())
        lines.append(f"| AS ({nu},{nv}) | {dt:.1f} | {conv.error:.2e} | {bad} / 16384 |")
    lines += [
        "",
        "## Kautz pass vs brute force, AS (24,8): relative RMS error",
        "",
        "| map | " + " | ".join(f"lmax {l}" for l in LMAXES) + " |",
        "|---|" + "---|" * len(LMAXES),
    ]
    for m in MAPS:
        e = kautz_errors(map_path(m))
        lines.append(f"| {m} | " + " | ".join(f"{e[l]:.2%}" for l in LMAXES) + " |")
    lines += ["", "## Settings report (`brdf-table --report`), 1024 samples, 128²", ""]
    for name, kw in [
        ("AS (12,4)", dict(nu=12, nv=4)),
        ("AS (24,8)", dict(nu=24, nv=8)),
        ("AS (48,16)", dict(nu=48, nv=16)),
    ] + [(f"GGX α {a}", dict(alpha=a)) for a in (0.1, 0.25, 0.5, 1.0)]:
        model = "ggx" if name.startswith("GGX") else "ashikhmin-shirley"
        b = make_brdf(model, **kw)
        _, conv = tabulate(b, 4, (128, 128), samples=1024)
        rep = settings_report(b, 4, (128, 128), 1024, conv.history)
        trunc = ", ".join(f"l{r['lmax']} {r['truncation_rel_l2']:.1%}" for r in rep["lmax"])
        res = ", ".join(
            f"{r['resolution']}² {r['lookup_error']:.1e} ({r['table_seconds']:.1f} s)"
            for r in rep["resolution"]
        )
        lines += [
            f"- **{name}**: f* truncation {trunc}; bilinear error (time) {res}; "
            f"quadrature error estimate at 1024 samples {conv.error:.1e}"
        ]
    out = ROOT / "bench" / "results" / "brdf_table.md"
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
