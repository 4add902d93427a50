"""What a probe fit's settings cost and how accurate they are (``probe-fit --report``, ``--tol``).

Two error sources, each against an independent or converged value:

* ``samples`` — the ``E0`` targets' own error: RMS of ``log(E0 / truth)`` over
  every ``SUBSET``-th fit sample, the truth being the plain visible-normal
  estimate at ``TRUTH_SAMPLES`` samples (:func:`ggx_integrals`). The time is
  one probe's targets: the per-map work (pyramid, bright texels) plus the
  per-target work measured on the subset and scaled to all targets.
* orders — the fit's own residual: RMS log residual of ``P Q`` against the
  targets of the chosen configuration (in-sample) for each ``(lmax_p,
  lmax_q)``, with its shaded relative error, the bytes per probe and the
  solve time.
* per ``α`` — the chosen fit's shaded relative error
  ``√(Σ 2n·v (PQ − E0)² / Σ 2n·v E0²)`` at each fit ``α`` (in-sample; what
  the ``shaded-nv`` weights minimise).

``--tol`` picks the fewest samples of :data:`SAMPLE_STUDY` whose target error
is at most the tolerance.
"""

import time
from dataclasses import replace

import numpy as np

from shbake.bakers.shexp import FitConfig, FitPlan
from shbake.bakers.shexp_targets import QuadraturePlan
from shbake.conventions import n_coeffs
from shbake.envmap.importance import bright_texels, latlong_pyramid
from shbake.errors import ParameterError
from shbake.reference.ggx import ggx_integrals

SAMPLE_STUDY = (256, 512, 1024, 2048, 4096)
ORDER_STUDY = ((2, 1), (3, 2), (4, 2), (6, 3), (8, 4))
TRUTH_SAMPLES = 1 << 16
SUBSET = 7


def _best_time(fn, *args, repeats: int = 3):
    """``(result, seconds)``: the fastest of ``repeats`` calls after one warm-up call."""
    result = fn(*args)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(*args)
        best = min(best, time.perf_counter() - t0)
    return result, best


def _map_work(flat, plan):
    bright_texels(flat, *plan.shape)
    latlong_pyramid(flat, plan.shape, plan.levels)


def _log_rms(values, truth, floor):
    return float(np.sqrt(np.mean(np.log(np.maximum(values, floor) / truth) ** 2)))


def samples_study(pixels, config: FitConfig) -> list[dict]:
    """Target error and gather time per sample count (module docstring)."""
    plan = FitPlan(replace(config, samples=64), pixels.shape[:2])  # geometry only
    pick = np.arange(0, plan.views.shape[0], SUBSET)
    v, n, r = plan.views[pick], plan.normals[pick], plan.alpha[pick]
    truth, _ = ggx_integrals(pixels, v, n, r, TRUTH_SAMPLES)
    floor = config.floor * truth.mean(axis=0)
    rows = []
    for samples in sorted(set(SAMPLE_STUDY) | {config.samples}):
        sub = QuadraturePlan.build(v, n, r, samples, pixels.shape[:2])
        e0, whole = _best_time(sub.e0, pixels)
        flat = np.ascontiguousarray(pixels.reshape(-1, 3), dtype=np.float32)
        _, per_map = _best_time(_map_work, flat, sub)
        seconds = per_map + max(0.0, whole - per_map) * plan.views.shape[0] / len(pick)
        rows.append({"samples": samples, "target_log_rms": _log_rms(e0, truth, floor),
                     "targets_seconds": seconds})  # fmt: skip
    return rows


def orders_study(pixels, config: FitConfig, e0) -> list[dict]:
    """In-sample fit residual, bytes and solve time per ``(lmax_p, lmax_q)``."""
    rows = []
    for lmax_p, lmax_q in sorted(set(ORDER_STUDY) | {(config.lmax_p, config.lmax_q)}):
        plan = FitPlan(replace(config, lmax_p=lmax_p, lmax_q=lmax_q, samples=64),
                       pixels.shape[:2])  # fmt: skip
        probe, seconds = _best_time(plan.fit_targets, e0)
        rows.append({"lmax_p": lmax_p, "lmax_q": lmax_q, "fit_log_rms": probe.stats["log_rms"],
                     "fit_shaded_rms": probe.stats["shaded_relative_rms"],
                     "bytes": 12 * config.sets * (n_coeffs(lmax_p) + n_coeffs(lmax_q) - 1),
                     "solve_seconds": seconds})  # fmt: skip
    return rows


def pick_samples(rows: list[dict], tol: float) -> int:
    """Fewest samples whose target error is within ``tol``."""
    ok = [r["samples"] for r in rows if r["target_log_rms"] <= tol]
    if not ok:
        best = min(rows, key=lambda r: r["target_log_rms"])
        raise ParameterError(
            f"no sample count up to {rows[-1]['samples']} meets --tol {tol:g} "
            f"(best: {best['target_log_rms']:.3g} at {best['samples']})"
        )
    return min(ok)


def alpha_rows(config: FitConfig, stats: dict) -> list[dict]:
    """The fit's shaded relative error per fit ``α`` from a probe's ``stats``."""
    return [{"alpha": float(a), "shaded_relative_rms": e}
            for a, e in zip(config.alphas, stats["shaded_relative_rms_by_alpha"], strict=True)]


def format_report(samples_rows: list[dict], order_rows: list[dict],
                  by_alpha: list[dict] = ()) -> str:  # fmt: skip
    """The report as small text tables."""
    lines = ["samples  target error (log RMS)  targets per probe (ms)"]
    lines += [
        f"{r['samples']:>7}  {r['target_log_rms']:>21.4f}  {1e3 * r['targets_seconds']:>22.1f}"
        for r in samples_rows
    ]
    lines += ["", "lmax_p lmax_q  fit residual (log RMS)  bytes/probe  solve (ms)"]
    lines += [
        f"{r['lmax_p']:>6} {r['lmax_q']:>6}  {r['fit_log_rms']:>22.4f}  {r['bytes']:>11}  "
        f"{1e3 * r['solve_seconds']:>10.1f}"
        for r in order_rows
    ]
    if by_alpha:
        lines += ["", "  alpha  fit shaded error (relative RMS)"]
        lines += [f"{r['alpha']:>7.4f}  {r['shaded_relative_rms']:>31.4f}" for r in by_alpha]
    return "\n".join(lines)
