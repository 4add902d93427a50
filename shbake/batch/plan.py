"""``shbake plan``: which assets a scene needs, at the cheapest settings meeting its tolerances.

Rules (one asset per map or per BRDF, shared by every material that needs it):

* ``diffuse`` → ``env_sh`` Lambert irradiance of every map (+ the sun when
  :func:`shbake.envmap.sun.extract_sun` finds one); ``fibre`` → the same
  asset's Kajiya–Kay tangent irradiance (one projection per map for both).
* ``anisotropic`` / ``measured`` → one ``brdf_table`` per distinct BRDF.
* ``glossy`` (GGX) → one SH-exp probe per map covering the materials whose
  GGX width α = r² starts at :data:`SHEXP_MIN_ALPHA` or above, when the fit's
  predicted error meets ``glossy_probe``; a split-sum probe per map for the
  rest (low roughness, or a fit that misses the tolerance).

Error models (cheap, each measured, never assumed):

* ``env_sh``: Parseval on the map itself. The map (sun removed when one is
  extracted) is projected to band :data:`ERROR_LMAX` once; the relative RMS
  error of irradiance truncated at ``L`` is ``sqrt(Σ_{l>L} K_l² e_l / Σ K_l² e_l)``
  (``e_l`` band energy, ``K_l`` the Lambert or Kajiya–Kay kernel), maximum
  over channels. Conservative with a sun: the sun is exact and only the
  residual's energy is counted in the denominator. Smallest ``L`` meeting
  the tolerance (at least 2 with a glTF export).
* ``brdf_table``: three parts, combined as ``sqrt(a² + b² + c²)``: lmax
  truncation of ``f*`` (Parseval against a dense quadrature, as
  :mod:`shbake.bakers.kautz_report`), sample noise (projection at the chosen
  samples vs :data:`REFERENCE_SAMPLES`), and bilinear look-up error of a
  table at each candidate size against direct projection; relative to
  ``‖f*(·, v)‖``, mean over :func:`~shbake.bakers.kautz_report.probe_views`.
* SH-exp: the fit's RMS log residual on the map downsampled to
  :data:`FIT_PREDICT_HEIGHT` rows (said in the plan's ``note``).
* split-sum: no error model in shbake (its approximation error is not a
  quadrature error); the plan says so instead of predicting one.

Predicted times are measured at plan time on the same machine: map loading,
the projection at the chosen ``L``, a small table scaled by texel count, a
fit on the downsampled map scaled by texel count.
"""

import hashlib
import json
import os
import time
from dataclasses import asdict

import numpy as np

from shbake.bakers.env_sh import band_energy
from shbake.bakers.kautz_report import probe_views, product_energy
from shbake.bakers.shexp import FIT_ALPHA_MIN, FitConfig
from shbake.bakers.splitsum import SplitSumConfig
from shbake.batch.scene import Scene, _param_strings
from shbake.brdf import make_brdf
from shbake.brdf.tabulate import project_views, tabulate
from shbake.conventions import n_coeffs
from shbake.envmap import load_environment
from shbake.envmap.environment import Environment as EnvMap
from shbake.envmap.sun import extract_sun
from shbake.sh.kernels import kajiya_kay_kernel, lambert_kernel
from shbake.texture.parabolic import fetch

ERROR_LMAX = 32
"""Band to which a map is projected once to predict truncation error."""
MAX_IRRADIANCE_LMAX = 16
SHEXP_MIN_ALPHA = FIT_ALPHA_MIN
"""Lowest GGX width α = r² the SH-exp fit takes (:data:`shbake.bakers.shexp.FIT_ALPHA_MIN`);
materials whose roughness range starts below ``sqrt(SHEXP_MIN_ALPHA)`` get split-sum."""
FIT_PREDICT_HEIGHT = 32
TABLE_LMAX = (2, 4, 6, 8)
TABLE_SIZES = (8, 16, 32, 64)
TABLE_SAMPLES = (256, 1024, 4096)
REFERENCE_SAMPLES = 16384
PLAN_VERSION = 4


def file_hash(path: str) -> str:
    """SHA-256 of a file's bytes (hex); special files (FIFO, ``/dev/zero``) are refused
    and no more than the file's size is read (:func:`shbake.resources.sha256_of`)."""
    from shbake import resources

    return resources.sha256_of(path)


def _digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def irradiance_truncation(coeffs: np.ndarray, kernel) -> np.ndarray:
    """Relative RMS error of kernel-convolved ``coeffs`` truncated at each band ``L``.

    Returns ``err[L]`` for ``L = 0 … lmax − 1`` (Parseval; maximum over channels).
    """
    e = band_energy(coeffs)
    lmax = e.shape[0] - 1
    k2 = kernel(lmax)[:, None] ** 2 * e
    total = np.maximum(k2.sum(axis=0), 1e-300)
    tail = np.cumsum(k2[::-1], axis=0)[::-1]  # tail[l] = Σ_{l' ≥ l}
    lost = np.vstack([tail[1:], np.zeros((1, e.shape[1]))]) / total
    return np.sqrt(np.clip(lost, 0.0, None)).max(axis=1)


_WARM: set[str] = set()
"""Kinds already called once in this process (numba cache loads, lazy imports done)."""


def _cold(kind: str, fn, *a, **k) -> float:
    """Warm seconds of ``fn(*a, **k)``: the first call per kind and process is not timed.

    Predicted times are warm times; the bake measures warm times too
    (:func:`shbake.batch.scene_bake.bake_asset`). A fresh process adds its
    numba cache loads (about 1–2 s per kind), which neither counts.
    """
    if kind not in _WARM:
        fn(*a, **k)
        _WARM.add(kind)
    best = _timed(fn, *a, **k)[1]
    for _ in range(2 if best < 0.05 else 0):  # short calls: the best of three (timer noise)
        best = min(best, _timed(fn, *a, **k)[1])
    return best


def _timed(fn, *a, **k):
    t0 = time.perf_counter()
    out = fn(*a, **k)
    return out, time.perf_counter() - t0


def _downsample(pixels: np.ndarray, height: int) -> np.ndarray:
    f = max(1, pixels.shape[0] // height)
    h, w = pixels.shape[0] // f * f, pixels.shape[1] // f * f
    p = pixels[:h, :w].reshape(h // f, f, w // f, f, -1).mean(axis=(1, 3))
    return np.ascontiguousarray(p, dtype=np.float32)


def plan_env_sh(env_path: str, env: EnvMap, load_s: float, irr_tol, tan_tol,
                exports: tuple = ()) -> dict:  # fmt: skip
    """Settings, predicted error and time of one map's ``env_sh`` asset (module docstring)."""
    (light, residual, rep), t_sun = _timed(extract_sun, env)
    sun = bool(rep["extracted"])
    coeffs, proj_s = _timed(residual.project, ERROR_LMAX)
    errs = {}
    if irr_tol is not None:
        errs["irradiance"] = (irradiance_truncation(coeffs, lambert_kernel), irr_tol)
    if tan_tol is not None:
        errs["tangent_irradiance"] = (irradiance_truncation(coeffs, kajiya_kay_kernel), tan_tol)
    lo = 2 if exports else 0  # engine exports carry 9 coefficients
    lmax = next((L for L in range(lo, MAX_IRRADIANCE_LMAX + 1)
                 if all(e[L] <= t for e, t in errs.values())), None)  # fmt: skip
    if lmax is None:
        return {"impossible": {k: float(e[MAX_IRRADIANCE_LMAX]) for k, (e, _) in errs.items()}}
    t_l = _cold("env_sh", residual.project, lmax)
    settings = {
        "lmax": lmax,
        "irradiance": irr_tol is not None,
        "tangent": tan_tol is not None,
        "extract_sun": sun,
    }
    n = n_coeffs(lmax) * 3 * 8
    return {
        "settings": settings,
        "predicted_error": {k: float(e[lmax]) for k, (e, _) in errs.items()},
        "predicted_seconds": load_s + t_l + (t_sun if sun else 0.0),
        "bytes": n * (1 + settings["irradiance"] + settings["tangent"]) + (56 if sun else 0),
        "note": "error: Parseval on the full map" + (", sun removed (exact light)" if sun else ""),
    }


def table_errors(brdf, lmax: int, size: int, samples: int, views=None, energy=None) -> dict:
    """The three relative errors of a ``(lmax, size, samples)`` table (module docstring)."""
    views = probe_views() if views is None else views
    energy = product_energy(brdf, views, 256) if energy is None else energy
    norm = np.sqrt(np.maximum(energy.sum(axis=1), 1e-300))
    ref, _ = project_views(brdf, views, lmax, samples=REFERENCE_SAMPLES)
    got, _ = project_views(brdf, views, lmax, samples=samples)
    kept = np.sum(ref * ref, axis=(1, 2))
    trunc = float(np.mean(np.sqrt(np.clip(energy.sum(axis=1) - kept, 0, None)) / norm))
    noise = float(np.mean(np.sqrt(np.sum((got - ref) ** 2, axis=(1, 2))) / norm))
    table, _ = tabulate(brdf, lmax, (size, size), samples=samples)
    look = float(np.mean(np.sqrt(np.sum((fetch(table, views) - got) ** 2, axis=(1, 2))) / norm))
    return {"truncation": trunc, "samples": noise, "lookup": look,
            "total": float(np.sqrt(trunc**2 + noise**2 + look**2))}  # fmt: skip


def plan_brdf_table(model: str, params: dict, merl: str | None, tol: float) -> dict:
    """Cheapest ``(lmax, size, samples)`` whose predicted error meets ``tol`` (greedy: lmax for
    60 % of it, then samples, then the smallest size meeting the whole)."""
    brdf = make_brdf(model, merl_path=merl, **_param_strings(params))
    views = probe_views()
    energy = product_energy(brdf, views, 256)
    norm = np.sqrt(np.maximum(energy.sum(axis=1), 1e-300))
    ref, _ = project_views(brdf, views, max(TABLE_LMAX), samples=REFERENCE_SAMPLES)
    lmax = TABLE_LMAX[-1]
    for L in TABLE_LMAX:
        kept = np.sum(ref[:, : n_coeffs(L)] ** 2, axis=(1, 2))
        if np.mean(np.sqrt(np.clip(energy.sum(axis=1) - kept, 0, None)) / norm) <= 0.6 * tol:
            lmax = L
            break
    samples = TABLE_SAMPLES[-1]
    for s in TABLE_SAMPLES:
        got, _ = project_views(brdf, views, lmax, samples=s)
        diff = np.sqrt(np.sum((got - ref[:, : n_coeffs(lmax)]) ** 2, axis=(1, 2)))
        if np.mean(diff / norm) <= 0.4 * tol:
            samples = s
            break
    t8 = _cold("brdf_table", tabulate, brdf, lmax, (8, 8), samples=samples)
    chosen = None
    for size in TABLE_SIZES:
        errs = table_errors(brdf, lmax, size, samples, views, energy)
        chosen = (size, errs)
        if errs["total"] <= tol:
            break
    size, errs = chosen
    out = {
        "settings": {"model": model, "params": params, "merl": merl, "lmax": lmax,
                     "size": size, "samples": samples},  # fmt: skip
        "predicted_error": {"brdf_table": errs["total"]},
        "predicted_seconds": t8 * (size / 8) ** 2,
        "bytes": size * size * n_coeffs(lmax) * 3 * 8,
        "note": "error: truncation {truncation:.3g}, samples {samples:.3g}, look-up {lookup:.3g}"
        .format(**errs),
    }
    if errs["total"] > tol:
        out["impossible"] = {"brdf_table": errs["total"]}
    return out


def plan_shexp(env: EnvMap, lo: float, hi: float, tol: float) -> dict:
    """An SH-exp probe over perceptual roughness ``[lo, hi]`` (α = r²): the paper's fit
    (one set, 4 α samples, 256 samples per target); error and time from a fit on a small map."""
    from shbake.bakers.shexp import FitPlan

    a_lo, a_hi = lo * lo, hi * hi
    config = FitConfig.paper(alpha_min=a_lo, alpha_max=a_hi,
                             alpha_count=4 if a_hi > a_lo else 1, samples=256)  # fmt: skip
    small = _downsample(env.pixels, FIT_PREDICT_HEIGHT)
    plan = FitPlan(config, small.shape[:2])  # the bake loads its plan from the plan cache
    probe = plan.fit(small)
    t_fit = _cold("shexp", plan.fit, small)
    return {
        "settings": {"fit": config.as_dict()},
        "predicted_error": {"glossy_probe": float(probe.stats["log_rms"])},
        "predicted_seconds": t_fit,
        "bytes": 12 * config.n_params,
        "note": f"error: fit on the map downsampled to {small.shape[0]} rows",
    }


def plan_splitsum(env: EnvMap, lo: float, hi: float) -> dict:
    """A split-sum probe covering perceptual roughness ``[lo, hi]`` (4 levels, α = r²
    evenly spaced); no error model (module docstring).

    Time: the chain prefiltered at half the size, scaled by texel count.
    """
    from shbake.bakers.splitsum import prefilter_chain

    a_lo = max(lo * lo, 1e-3)
    a_hi = max(hi * hi, a_lo + 0.01)
    alphas = tuple(float(a) for a in np.linspace(a_lo, min(a_hi, 1.0), 4))
    config = SplitSumConfig(top=64, min_size=16, alphas=alphas, samples=256)
    small = SplitSumConfig(**(config.as_dict() | {"top": 32, "min_size": 8}))
    t = _cold("splitsum", prefilter_chain, env.pixels, small)
    texels = sum(s * s for s in config.sizes)
    return {
        "settings": {"splitsum": config.as_dict()},
        "predicted_error": {},
        "predicted_seconds": t * texels / sum(s * s for s in small.sizes),
        "bytes": 12 * texels,
        "note": "split-sum: no error model (approximation, not quadrature); tolerance not checked",
    }


def plan_scene(scene: Scene, cache: dict | None = None) -> dict:
    """The plan of ``scene``: ``{"assets": [...], "materials": {...}}``.

    ``cache``: earlier per-unit plans keyed by their inputs (the lock's
    ``plans``); a unit whose key is there is not re-measured.
    """
    cache = {} if cache is None else cache
    kinds = {m.kind for m in scene.materials}
    glossy = [m for m in scene.materials if m.kind == "glossy"]
    assets = []
    used = {m.name: [] for m in scene.materials}
    for env in scene.environments:
        digest = file_hash(env.map)
        needs_sh = kinds & {"diffuse", "fibre"}
        env_map = None
        load_s = 0.0

        def get_env(path=env.map):
            nonlocal env_map, load_s
            if env_map is None:
                env_map, load_s = _timed(load_environment, path, quiet=True)
                if "load" not in _WARM:  # the first load also pays imports: time it again
                    _WARM.add("load")
                    env_map, load_s = _timed(load_environment, path, quiet=True)
            return env_map

        if needs_sh:
            irr = scene.tolerance("irradiance", env) if "diffuse" in kinds else None
            tan = scene.tolerance("tangent_irradiance", env) if "fibre" in kinds else None
            exports = tuple(scene.exports)
            key = _digest(["env_sh", PLAN_VERSION, digest, irr and irr[0], tan and tan[0],
                           sorted(exports)])  # fmt: skip
            if key not in cache:
                get_env()
                cache[key] = plan_env_sh(env.map, env_map, load_s, irr and irr[0],
                                         tan and tan[0], exports)  # fmt: skip
            p = cache[key]
            if "impossible" in p:
                k = next(iter(p["impossible"]))
                tol, tkey = irr if k == "irradiance" else tan
                raise scene.error(tkey, f"impossible tolerance {tol:g} for {env.name}: lmax "
                                  f"{MAX_IRRADIANCE_LMAX} reaches {p['impossible'][k]:.3g}")
            aid = f"env_sh/{env.name}"
            tols = {k: v for k, v in (("irradiance", irr), ("tangent_irradiance", tan)) if v}
            assets.append(_asset(aid, "env_sh", scene, p, [env.map], {"map": digest}, key, tols))
            for m in scene.materials:
                if m.kind in ("diffuse", "fibre"):
                    used[m.name].append(aid)
            env_sh_out = assets[-1]["output"]
            for target in sorted(exports):
                if irr is None:
                    raise scene.error("scene.exports", "engine exports need a diffuse material "
                                      "(they carry the irradiance SH)")  # fmt: skip
                eid = f"export/{target}/{env.name}"
                assets.append({
                    "id": eid, "kind": "export",
                    "output": os.path.join(scene.out_dir, "export", target, env.name,
                                           "files.json"),
                    "inputs": [env.map, env_sh_out], "input_hashes": {"map": digest},
                    "plan_key": _digest(["export", PLAN_VERSION, key, target]),
                    "settings": {"target": target, "env_sh": aid},
                    "tolerances": {}, "predicted_error": {}, "predicted_seconds": None,
                    "bytes": None, "note": "engine export: no error or time model",
                })  # fmt: skip
        if glossy:
            tol, tkey = scene.tolerance("glossy_probe", env)
            high = [m for m in glossy if m.roughness[0] ** 2 >= SHEXP_MIN_ALPHA]
            low = [m for m in glossy if m.roughness[0] ** 2 < SHEXP_MIN_ALPHA]
            if high:
                lo = min(m.roughness[0] for m in high)
                hi = max(m.roughness[1] for m in high)
                key = _digest(["shexp", PLAN_VERSION, digest, lo, hi, tol])
                if key not in cache:
                    cache[key] = plan_shexp(get_env(), lo, hi, tol)
                    cache[key]["predicted_seconds"] += load_s
                p = cache[key]
                if p["predicted_error"]["glossy_probe"] <= tol:
                    aid = f"shexp/{env.name}"
                    assets.append(_asset(aid, "shexp", scene, p, [env.map], {"map": digest},
                                         key, {"glossy_probe": (tol, tkey)}))  # fmt: skip
                    for m in high:
                        used[m.name].append(aid)
                else:
                    low += high
            if low:
                lo = min(m.roughness[0] for m in low)
                hi = max(m.roughness[1] for m in low)
                key = _digest(["splitsum", PLAN_VERSION, digest, lo, hi])
                if key not in cache:
                    cache[key] = plan_splitsum(get_env(), lo, hi)
                    cache[key]["predicted_seconds"] += load_s
                aid = f"splitsum/{env.name}"
                assets.append(_asset(aid, "splitsum", scene, cache[key], [env.map],
                                     {"map": digest}, key, {}))  # fmt: skip
                for m in low:
                    used[m.name].append(aid)
    tables = {}
    for m in scene.materials:
        if m.kind not in ("anisotropic", "measured"):
            continue
        tol, tkey = scene.tolerance("brdf_table")
        spec = [m.model, m.params, m.merl and file_hash(m.merl)]
        sid = _digest(spec)
        if sid not in tables:
            key = _digest(["brdf_table", PLAN_VERSION, spec, tol])
            if key not in cache:
                cache[key] = plan_brdf_table(m.model, m.params, m.merl, tol)
            p = cache[key]
            if "impossible" in p:
                raise scene.error(tkey, f"impossible tolerance {tol:g} for {m.name}: the best "
                                  f"table reaches {p['impossible']['brdf_table']:.3g}")
            aid = f"brdf_table/{m.name}"
            inputs = [m.merl] if m.merl else []
            assets.append(_asset(aid, "brdf_table", scene, p, inputs, {}, key,
                                 {"brdf_table": (tol, tkey)}))  # fmt: skip
            tables[sid] = aid
        used[m.name].append(tables[sid])
    return {"scene": scene.path, "name": scene.name, "out_dir": scene.out_dir,
            "assets": assets, "materials": used}  # fmt: skip


def _asset(aid, kind, scene, p, inputs, hashes, key, tolerances) -> dict:
    return {
        "id": aid,
        "kind": kind,
        "output": os.path.join(scene.out_dir, aid + ".h5"),
        "inputs": inputs,
        "input_hashes": hashes,
        "plan_key": key,
        "settings": p["settings"],
        "tolerances": {k: v[0] for k, v in tolerances.items()},
        "predicted_error": p["predicted_error"],
        "predicted_seconds": p["predicted_seconds"],
        "bytes": p["bytes"],
        "note": p["note"],
    }


def settings_text(asset: dict) -> str:
    """What decides an asset's bytes (kind, settings, inputs' hashes): its stamp file's text."""
    keep = {k: asset[k] for k in ("id", "kind", "output", "inputs", "input_hashes", "settings")}
    return json.dumps(keep, sort_keys=True, indent=1) + "\n"


def format_plan(plan: dict) -> str:
    """The plan as a text table: asset, settings, predicted error (tolerance), time, bytes."""
    rows = [("asset", "settings", "pred. error (tol)", "pred. s", "bytes")]
    for a in plan["assets"]:
        s = a["settings"]
        if a["kind"] == "env_sh":
            text = f"lmax {s['lmax']}" + (" +sun" if s["extract_sun"] else "")
        elif a["kind"] == "brdf_table":
            text = f"lmax {s['lmax']} size {s['size']} samples {s['samples']}"
        elif a["kind"] == "shexp":
            f = s["fit"]
            text = (f"P{f['lmax_p']} Q{f['lmax_q']} a {f['alpha_min']:.3g}-"
                    f"{f['alpha_max']:.3g} samples {f['samples']}")  # fmt: skip
        elif a["kind"] == "export":
            text = f"{s['target']} of {s['env_sh']}"
        else:
            c = s["splitsum"]
            text = (f"{len(c['alphas'])} levels {c['top']}..{c['min_size']} a "
                    f"{c['alphas'][0]:.3g}-{c['alphas'][-1]:.3g}")  # fmt: skip
        err = ", ".join(f"{v:.3g} ({a['tolerances'].get(k, float('nan')):g})"
                        for k, v in a["predicted_error"].items()) or "n/a"  # fmt: skip
        secs = "n/a" if a["predicted_seconds"] is None else f"{a['predicted_seconds']:.2f}"
        rows.append((a["id"], text, err, secs, "n/a" if a["bytes"] is None else str(a["bytes"])))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    lines = ("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows)
    return "\n".join(line.rstrip() for line in lines)


__all__ = ["plan_scene", "format_plan", "settings_text", "file_hash", "asdict"]
