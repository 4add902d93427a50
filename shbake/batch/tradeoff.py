"""``shbake tradeoff``: error against time and bytes for the settings the planner considers.

One row per candidate setting, with the error model of :mod:`shbake.batch.plan`
(the same numbers the planner compares with a tolerance), the measured warm CPU
time of the baker's own work at that setting and the asset's payload bytes;
the chosen setting is marked: the one ``shbake plan`` picks, by its rule over the
errors alone, never by the measured times (``env_sh``: the smallest lmax meeting
``tol``; ``brdf_table``: the planner's lmax, :func:`~shbake.batch.plan.table_lmax`,
then the smallest size meeting ``tol``; the samples are ``samples``, not the planner's).
Written as a PNG (matplotlib: error vs time and error vs bytes, log axes, tolerance line,
chosen point), a CSV and a JSON file.
"""

import csv
import io
import json
import os

import numpy as np

from shbake.bakers.brdf_table_report import probe_views, product_energy
from shbake.batch.plan import (
    ERROR_LMAX,
    MAX_IRRADIANCE_LMAX,
    REFERENCE_SAMPLES,
    TABLE_LMAX,
    TABLE_SIZES,
    TableErrors,
    irradiance_truncation,
    table_lmax,
)
from shbake.batch.plan_costs import warm_seconds
from shbake.batch.scene import param_strings
from shbake.brdf import make_brdf
from shbake.brdf.tabulate import project_views, tabulate
from shbake.conventions import n_coeffs
from shbake.envmap import load_environment
from shbake.envmap.sun import extract_sun
from shbake.errors import ParameterError
from shbake.format.atomic import atomic_path, check_output_path, write_text
from shbake.messages import warn
from shbake.resources import path_arguments
from shbake.sh.kernels import kajiya_kay_kernel, lambert_kernel

TRADEOFF_KINDS = ("env_sh", "brdf_table")


@path_arguments("map_path")
def env_sh_tradeoff(map_path: str, tol: float, sun: bool = True) -> dict:
    """Rows ``lmax, error (irradiance / tangent), seconds, bytes`` for ``lmax = 0 … 16``."""
    env = load_environment(map_path, quiet=True)
    residual = extract_sun(env)[1] if sun else env
    coeffs = residual.project(ERROR_LMAX)
    e_irr = irradiance_truncation(coeffs, lambert_kernel)
    e_tan = irradiance_truncation(coeffs, kajiya_kay_kernel)
    rows = []
    for L in range(MAX_IRRADIANCE_LMAX + 1):
        rows.append({"setting": f"lmax {L}", "lmax": L, "error": float(max(e_irr[L], e_tan[L])),
                     "irradiance_error": float(e_irr[L]), "tangent_error": float(e_tan[L]),
                     "seconds": warm_seconds("env_sh", residual.project, L),
                     "bytes": 3 * n_coeffs(L) * 3 * 8})  # fmt: skip
    return _finish("env_sh", rows, rows, tol, "relative RMS irradiance error (Parseval)",
                   map_path)  # fmt: skip


def brdf_table_tradeoff(model: str, params: dict, tol: float, samples: int = 256) -> dict:
    """Rows ``(lmax, size)`` over TABLE_LMAX × TABLE_SIZES[:3] at ``samples``; the chosen one
    at the planner's lmax (:func:`~shbake.batch.plan.table_lmax` of the rows' truncation)."""
    brdf = make_brdf(model, **param_strings(params))
    views = probe_views()
    energy = product_energy(brdf, views, 256)
    ref, _ = project_views(brdf, views, max(TABLE_LMAX), samples=REFERENCE_SAMPLES)
    got, _ = project_views(brdf, views, max(TABLE_LMAX), samples=samples)
    rows, truncation = [], {}
    for L in TABLE_LMAX:
        errors = TableErrors(brdf, L, samples, views, energy, ref, got[:, : n_coeffs(L)])
        truncation[L] = errors.truncation
        for size in TABLE_SIZES[:3]:
            errs = errors.at(size)
            rows.append({"setting": f"lmax {L} size {size}", "lmax": L, "size": size,
                         "samples": samples, "error": errs["total"], **{
                             f"{k}_error": v for k, v in errs.items() if k != "total"},
                         "seconds": warm_seconds("brdf_table", tabulate, brdf, L, (size, size),
                                          samples=samples),
                         "bytes": size * size * n_coeffs(L) * 3 * 8})  # fmt: skip
    lmax = table_lmax(truncation.__getitem__, tol)
    candidates = [r for r in rows if r["lmax"] == lmax]  # by size, smallest first
    return _finish("brdf_table", rows, candidates, tol, "relative L2 error of f*", model,
                   f" at the planner's lmax {lmax}")  # fmt: skip


def _finish(kind, rows, candidates, tol, error_label, source, among="") -> dict:
    """The result: ``rows`` and the chosen setting, the first of ``candidates`` (the rows the
    planner's rule considers, in its order) meeting ``tol``; none: a warning naming the
    least error of any row (``among``: where the candidates are, for the warning)."""
    chosen = next((r for r in candidates if r["error"] <= tol), None)
    if chosen is None:
        best = min(rows, key=lambda r: r["error"])
        warn(f"no setting{among} meets --tol {tol:g} ({error_label}); the least error is "
             f"{best['error']:.3g}, at {best['setting']}")  # fmt: skip
    return {"kind": kind, "source": source, "tolerance": tol, "error_label": error_label,
            "rows": rows, "chosen": chosen and chosen["setting"]}  # fmt: skip


@path_arguments("output", "csv_path", "json_path")
def write_tradeoff(result: dict, output: str, csv_path: str | None, json_path: str | None):
    """The PNG at ``output`` and the numbers as CSV / JSON (each atomically)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["rows"]
    err = np.array([max(r["error"], 1e-12) for r in rows])
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), dpi=100)
    for ax, key, label in ((axes[0], "seconds", "work (CPU s, warm)"), (axes[1], "bytes", "bytes")):
        x = np.array([max(r[key], 1e-6) for r in rows], float)
        ax.scatter(x, err, s=14, c="tab:blue", label="settings considered")
        for r, xi, ei in zip(rows, x, err, strict=True):
            if r["setting"] == result["chosen"]:
                ax.scatter([xi], [ei], s=90, facecolors="none", edgecolors="tab:red",
                           linewidths=2, label=f"chosen: {r['setting']}")  # fmt: skip
        ax.axhline(result["tolerance"], color="tab:red", ls="--",
                   label=f"tolerance {result['tolerance']:g}")  # fmt: skip
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel(result["error_label"])
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{result['kind']}: {os.path.basename(str(result['source']))}")
    fig.tight_layout()
    with atomic_path(output) as tmp:
        fig.savefig(tmp, format="png", metadata={"Software": None})
    plt.close(fig)
    if csv_path:
        keys = list(dict.fromkeys(k for r in rows for k in r))
        buf = io.StringIO()
        w = csv.DictWriter(buf, keys + ["chosen"], lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow(r | {"chosen": int(r["setting"] == result["chosen"])})
        write_text(csv_path, buf.getvalue())
    if json_path:
        write_text(json_path, json.dumps(result, indent=1) + "\n")


@path_arguments("map_path")
def tradeoff(kind: str, tol: float, map_path: str | None = None, model: str | None = None,
             params: dict | None = None, samples: int = 256) -> dict:  # fmt: skip
    """Dispatch on ``kind`` (one of :data:`TRADEOFF_KINDS`), validating what it needs."""
    if not 0.0 < tol < 1.0:
        raise ParameterError(f"--tol must be in (0, 1), got {tol}")
    if kind == "env_sh":
        if map_path is None:
            raise ParameterError("tradeoff env_sh needs --map")
        return env_sh_tradeoff(map_path, tol)
    if model is None:
        raise ParameterError("tradeoff brdf_table needs --model")
    return brdf_table_tradeoff(model, params or {}, tol, samples)


@path_arguments("output", "csv_path", "json_path")
def tradeoff_files(kind: str, tol: float, output: str, csv_path: str | None = None,
                   json_path: str | None = None, **inputs) -> dict:  # fmt: skip
    """:func:`tradeoff` (``inputs``: its ``map_path``, ``model``, ``params``, ``samples``)
    written by :func:`write_tradeoff`; the outputs are checked before any work (a missing
    folder, an output that is the map: one line at once, not after the sweep)."""
    for path, option in ((output, "-o/--output"), (csv_path, "--csv"), (json_path, "--json-file")):
        if path:
            check_output_path(path, option)
    result = tradeoff(kind, tol, **inputs)
    write_tradeoff(result, output, csv_path, json_path)
    return result
