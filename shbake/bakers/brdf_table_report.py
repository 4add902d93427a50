"""What a table's settings cost and how accurate they are (``brdf-table --report``).

Three independent error sources, each against a brute-force or converged value:

* ``lmax`` — truncation of ``f*(·, v)`` to bands ≤ lmax: relative L2 error
  ``sqrt(1 − Σ_i c_i² / ∫ f*² ds)`` (Parseval), ``∫ f*²`` by a 1024 × 2048
  Gauss–Legendre × trapezoid hemisphere quadrature; mean over probe views.
* resolution — bilinear look-up error: ``sqrt(4π) max |c_lookup(v) − c(v)|``
  at random views (``c(v)`` projected directly with the same samples). The
  study's tables use at most :data:`RESOLUTION_STUDY_SAMPLES` points per view
  (the same for the direct values, so the difference is the look-up alone) and are
  computed only at the texels the look-up reads
  (:func:`shbake.brdf.tabulate.tabulate_at`: the whole 256² table was 6 of the report's
  11 s for Ashikhmin–Shirley (24, 8) at 32²).
* samples — the table's own refinement history (error estimate per power-of-two of points).

Times are predictions anchored to the measured bake: the bake's own seconds, scaled by
each setting's cost relative to the chosen setting's (the measured per-view projection
cost for ``lmax``; for the resolution the views a table integrates, ``⌈H/2⌉ ⌈W/2⌉`` at
the same cost each), so the chosen setting's estimate is the bake's time.
"""

import time

import numpy as np

from shbake.brdf.model import BRDF
from shbake.brdf.tabulate import SQRT_4PI, project_views, quadrant_views, tabulate_at
from shbake.sh.point_sets import gauss_legendre
from shbake.texture.parabolic import fetch

LMAX_STUDY = (2, 4, 6, 8)
RESOLUTION_STUDY = (32, 64, 128, 256)
RESOLUTION_STUDY_SAMPLES = 1024
"""Points per view of the resolution study's tables: at a refined table's full count the
study cost ~100× the table itself (Ashikhmin–Shirley (24, 8) at 32², ``--tol 1e-3``:
8704 points per view, 108 s against 1 s)."""


def probe_views(count: int = 16, seed: int = 7) -> np.ndarray:
    """Deterministic random unit views in the upper hemisphere, two of them grazing (z = 0.05)."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(count, 3))
    v[:, 2] = np.abs(v[:, 2])
    v[:2, 2] = 0.0
    v[:2] /= np.linalg.norm(v[:2], axis=1, keepdims=True)
    v[:2] *= np.sqrt(1 - 0.05**2)
    v[:2, 2] = 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def product_energy(brdf: BRDF, views: np.ndarray, n_theta: int = 1024) -> np.ndarray:
    """``∫ f*(s, v)² ds`` per view and channel: a product rule in polar coordinates about the
    view's mirror direction ``r``, ``θ' = π u²`` (Gauss–Legendre in ``u``, uniform in
    ``φ'``), so that a lobe about ``r`` as narrow as ``π / n_theta²`` rad is resolved (a
    rule about the normal missed a Blinn–Phong lobe of exponent 10⁶: energy 0, and a
    relative error of 1e147); ``f*`` is 0 below the horizon."""
    x, w = gauss_legendre(n_theta)
    u = 0.5 * (x + 1.0)
    theta = np.pi * u * u
    wt = 0.5 * w * 2.0 * np.pi * u * np.sin(theta)  # du/dx · dθ'/du · sin θ'
    n_phi = 2 * n_theta
    phi = 2 * np.pi * (np.arange(n_phi) + 0.5) / n_phi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    local = np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), ct), -1)
    local = local.reshape(-1, 3)
    weight = (wt[:, None] * np.full(n_phi, 2 * np.pi / n_phi)).reshape(-1)
    out = []
    for v in views:
        r = np.array([-v[0], -v[1], v[2]])  # the mirror direction about +Z
        a = np.array([1.0, 0.0, 0.0]) if abs(r[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        t = np.cross(r, a)
        t /= np.linalg.norm(t)
        s = local @ np.stack([t, np.cross(r, t), r])
        up = s[:, 2] > 0.0
        fs = brdf.evaluate(s[up], v) * s[up, 2:3]
        out.append(weight[up] @ (fs * fs))
    return np.array(out)


def settings_report(
    brdf: BRDF, lmax: int, resolution: tuple[int, int], samples: int, history: list,
    bake_seconds: float,
) -> dict:  # fmt: skip
    """Error and time of the chosen settings and their neighbours (see module docstring);
    ``bake_seconds``: what the table of the chosen settings took."""
    views = probe_views()
    energy = product_energy(brdf, views)
    h, w = resolution
    by_lmax = []
    for l in sorted(set(LMAX_STUDY) | {lmax}):
        t0 = time.perf_counter()
        c, _ = project_views(brdf, views, l, samples=samples)
        dt = (time.perf_counter() - t0) / len(views)
        kept = np.sum(c * c, axis=1)
        rel = np.sqrt(np.clip(1.0 - kept / np.maximum(energy, 1e-300), 0.0, None))
        by_lmax.append(
            {
                "lmax": l,
                "truncation_rel_l2": float(np.mean(rel[energy > 0])) if np.any(energy > 0) else 0.0,
                "per_view_seconds": dt,
            }
        )
    chosen = next(r["per_view_seconds"] for r in by_lmax if r["lmax"] == lmax)
    for r in by_lmax:
        r["est_table_seconds"] = bake_seconds * r.pop("per_view_seconds") / chosen
    test_views = probe_views(64, seed=11)
    study = min(samples, RESOLUTION_STUDY_SAMPLES)
    direct, _ = project_views(brdf, test_views, lmax, samples=study)
    by_res = []
    for r in sorted(set(RESOLUTION_STUDY) | {h}):
        table = tabulate_at(brdf, lmax, (r, r), test_views, samples=study)
        err = SQRT_4PI * float(np.max(np.abs(fetch(table, test_views) - direct)))
        # a table integrates its quadrant's texels, each at the same cost
        scale = len(quadrant_views(r, r)) / len(quadrant_views(h, w))
        by_res.append({"resolution": r, "lookup_error": err,
                       "est_table_seconds": bake_seconds * scale})  # fmt: skip
    return {"lmax": by_lmax, "resolution": by_res, "samples": history}


def format_report(rep: dict) -> str:
    """The report as three small text tables."""
    lines = ["lmax  f* truncation (rel. L2)  est. table time (s)"]
    lines += [
        f"{r['lmax']:>4}  {r['truncation_rel_l2']:>23.4%}  {r['est_table_seconds']:>19.2f}"
        for r in rep["lmax"]
    ]
    lines += ["", "res   bilinear look-up error  est. table time (s)"]
    lines += [
        f"{r['resolution']:>4}  {r['lookup_error']:>22.2e}  {r['est_table_seconds']:>19.2f}"
        for r in rep["resolution"]
    ]
    lines += ["", "samples  views refined  error estimate  cumulative time (s)"]
    lines += [
        f"{r['samples']:>7}  {r['views']:>13}  {r['error_estimate']:>14.2e}  {r['seconds']:>19.2f}"
        for r in rep["samples"]
    ]
    return "\n".join(lines)
