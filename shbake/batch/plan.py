"""``shbake plan``: which assets a scene needs, at the cheapest settings meeting its tolerances.

Rules (one asset per map or per BRDF, shared by every material that needs it):

* ``diffuse`` → ``env_sh`` Lambert irradiance of every map (+ the sun when
  :func:`shbake.envmap.sun.extract_sun` finds one); ``fibre`` → the same
  asset's Kajiya–Kay tangent irradiance (one projection per map for both).
* ``anisotropic`` / ``measured`` → one ``brdf_table`` per distinct BRDF.
* ``glossy`` (GGX) → one SH-exp probe per map covering the materials whose
  GGX width α = r² starts at :data:`SHEXP_MIN_ALPHA` or above, when the fit's
  predicted error meets ``glossy_probe``; a split-sum probe per map for the
  rest (low roughness, or a fit that misses the tolerance: the note names the
  materials, the fit's residual and the tolerance) — except a material
  with ONE roughness whose SHRM orders meet ``shrm``: it gets an SHRM. A
  dielectric (``params.F0`` below :data:`SHEXP_DIELECTRIC_F0`) whose range starts
  below :data:`SHEXP_DIELECTRIC_ALPHA` goes to the split-sum (or SHRM) too, the
  asset's note says why: there SH-exp loses to the plain split-sum in more than 10 %
  of the shared-map cases.
* ``glossy`` with another isotropic ``model`` (Phong, Blinn–Phong, Ward,
  microfacet σ, Lafortune…) → one SHRM per map and distinct BRDF.

Error models (cheap, each measured, never assumed):

* ``env_sh``: Parseval on the map itself. The map (sun removed when one is
  extracted) is projected to band :data:`ERROR_LMAX` once; the relative RMS
  error of irradiance truncated at ``L`` is ``sqrt(Σ_{l>L} K_l² e_l / Σ K_l² e_l)``
  (``e_l`` band energy, ``K_l`` the Lambert or Kajiya–Kay kernel), maximum
  over channels. Conservative with a sun: the sun is exact and only the
  residual's energy is counted in the denominator. Smallest ``L`` meeting
  the tolerance (at least 2 with a glTF export). With engine exports and no
  fibre (engines read 9 coefficients and a few lights), the lights fitted with the
  SH to the irradiance come first (:mod:`shbake.bakers.env_lights`): the fewest
  (0 … :data:`~shbake.bakers.env_lights.AUTO_MAX_LIGHTS`) whose relative RMS error
  against brute force at the fit's normals meets the tolerance, at ``L = 2``;
  the Parseval rule when none does.
* ``brdf_table``: three parts, combined as ``sqrt(a² + b² + c²)``: lmax
  truncation of ``f*`` (Parseval against a dense quadrature, as
  :mod:`shbake.bakers.brdf_table_report`), sample noise (projection at the chosen
  samples vs :data:`REFERENCE_SAMPLES`), and bilinear look-up error of a
  table at each candidate size against direct projection; relative to
  ``‖f*(·, v)‖``, mean over :func:`~shbake.bakers.brdf_table_report.probe_views`.
* SH-exp: the RMS log residual of the fit the bake writes (:func:`plan_shexp`: the
  plan fits the map and keeps the probe for the bake).
* split-sum: no error model in shbake (its approximation error is not a
  quadrature error); the plan says so instead of predicting one.
* SHRM: the BRDF energy the orders ``F``, ``P`` leave out (RH02 §5.1,
  :func:`shbake.brdf.reflection.select_orders`).

Predicted times are CPU seconds of each asset's make recipe: the recipe's
fixed part (:func:`shbake.batch.plan_costs.recipe_overheads`, once per
machine) plus the map load and the baker's work, CPU time measured here
(:mod:`shbake.batch.plan_costs` says what the number means).
"""

import hashlib
import json
import os
from dataclasses import asdict

import numpy as np

from shbake.bakers.brdf_table_report import probe_views, product_energy
from shbake.bakers.env_lights import AUTO_MAX_LIGHTS, choose_lights, irradiance_target
from shbake.bakers.env_sh import band_energy, project_lighting
from shbake.bakers.shexp import FIT_ALPHA_MIN, FitConfig
from shbake.bakers.splitsum import SplitSumConfig
from shbake.batch.plan_costs import (
    WARMED,
    cpu_timed,
    recipe_overheads,
    shape_seconds,
    warm_seconds,
)
from shbake.batch.scene import Scene, asset_output, param_strings
from shbake.brdf import make_brdf
from shbake.brdf.reflection import F_LIMIT, P_LIMIT
from shbake.brdf.tabulate import project_views, tabulate
from shbake.conventions import ggx_alpha, n_coeffs
from shbake.envmap import load_environment
from shbake.envmap.environment import Environment as EnvMap
from shbake.envmap.sun import SUN_RADIUS_DEG, extract_sun
from shbake.evaluation.metrics import mean_relative_norm
from shbake.resources import path_arguments
from shbake.sh.kernels import kajiya_kay_kernel, lambert_kernel
from shbake.texture.parabolic import fetch

ERROR_LMAX = 32
"""Band to which a map is projected once to predict truncation error."""
MAX_IRRADIANCE_LMAX = 16
SHEXP_MIN_ALPHA = FIT_ALPHA_MIN
"""Lowest GGX width α = r² the SH-exp fit takes (:data:`shbake.bakers.shexp.FIT_ALPHA_MIN`);
materials whose roughness range starts below ``sqrt(SHEXP_MIN_ALPHA)`` get split-sum."""
SHEXP_DIELECTRIC_F0 = 0.5
"""Schlick ``F0`` below which a GGX material is a dielectric for :data:`SHEXP_DIELECTRIC_ALPHA`."""
SHEXP_DIELECTRIC_ALPHA = 0.25
"""GGX width below which SH-exp (the default fit) loses to the plain split-sum for
dielectrics (F0 0.04) in more than 10 % of the 24 shared-map cases per α: α 0.2 wins 15/24,
α 0.25 22/24, 0.36 and above 24/24 (docs/BENCHMARKS.md). Chrome wins 23/24 at both 0.2 and
0.25: a dielectric's image is ``0.04 E0`` near normal incidence, where the split-sum is
nearly exact at small α, so the fit's ``E0`` error there decides."""
TABLE_LMAX = (2, 4, 6, 8)
TABLE_SIZES = (8, 16, 32, 64)
TABLE_SAMPLES = (256, 1024, 4096)
REFERENCE_SAMPLES = 16384
PLAN_VERSION = 8


_HASHED: dict = {}


@path_arguments("path")
def file_hash(path: str, own_output: bool = False) -> str:
    """SHA-256 of a file's bytes (hex); special files (FIFO, ``/dev/zero``) are refused
    and no more than the file's size is read (:func:`shbake.resources.sha256_of`;
    ``own_output``: a file the scene's bake wrote, not an input of the run). A regular file
    is hashed once per process while its identity and times are unchanged (device, inode,
    size, modification and change times: rewriting or replacing it changes them), whatever
    name it is read by, so a plan and the bake after it in one process read each map once,
    and links to one map (10,000 probes on six maps) read it once."""
    import stat

    from shbake import resources

    try:
        st = os.stat(path)
    except OSError:
        st = None
    key = None
    if st is not None and stat.S_ISREG(st.st_mode):
        key = (own_output, st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
        if key in _HASHED:
            if not own_output:  # this name is an input too, as sha256_of records it
                resources.note_input(path)
            return _HASHED[key]
    digest = resources.sha256_of(path, own_output)
    if key is not None:
        _HASHED[key] = digest
    return digest


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


_timed = cpu_timed


def plan_env_sh(env_path: str, env: EnvMap, load_s: float, irr_tol, tan_tol,
                exports: tuple = ()) -> dict:  # fmt: skip
    """Settings, predicted error and time of one map's ``env_sh`` asset (module docstring)."""
    if exports and irr_tol is not None and tan_tol is None:
        lit = _plan_lights(env, load_s, irr_tol)
        if lit is not None:
            return lit
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
    t_l = shape_seconds("env_sh", (residual.layout, residual.shape, lmax), residual.project,
                        lmax)  # fmt: skip
    # what the bake projects, made here once (the same calls: the same bits)
    projection = project_lighting(env, lmax, SUN_RADIUS_DEG if sun else None,
                                  (light, residual, rep))  # fmt: skip
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
        "work_seconds": load_s + t_l + (t_sun if sun else 0.0),
        "sun_seconds": t_sun if sun else 0.0,
        "bytes": n * (1 + settings["irradiance"] + settings["tangent"]) + (56 if sun else 0),
        "note": "error: Parseval on the full map" + (", sun removed (exact light)" if sun else ""),
        "projection": projection.to_record(),
    }


def _plan_lights(env: EnvMap, load_s: float, irr_tol: float) -> dict | None:
    """The ``env_sh`` plan with fitted lights at ``L = 2`` (module docstring), or None
    when no fit with up to :data:`AUTO_MAX_LIGHTS` lights meets ``irr_tol``."""

    def fit():
        return choose_lights(irradiance_target(env), irr_tol, AUTO_MAX_LIGHTS, 2, "rms_error")

    (best, _), seconds = _timed(fit)
    if best.rms_error > irr_tol:
        return None
    settings = {"lmax": 2, "irradiance": True, "tangent": False, "extract_sun": False,
                "lights": best.count}  # fmt: skip
    return {
        "settings": settings,
        "predicted_error": {"irradiance": best.rms_error},
        "work_seconds": load_s + seconds,
        "bytes": n_coeffs(2) * 3 * 8 * 2 + 48 * best.count,
        "note": f"error: SH + {best.count} lights fitted to brute-force irradiance "
        "(relative RMS at the fit's normals)",
    }


class TableErrors:
    """The three relative errors of ``(lmax, size, samples)`` tables (module docstring).

    The truncation and sample terms do not depend on the table size and are
    measured once, here (:attr:`truncation`, :attr:`samples`); :meth:`at`
    adds the look-up term of one size. ``reference``: the views projected at
    :data:`REFERENCE_SAMPLES` to ``lmax`` or beyond, if the caller has it (a
    coefficient's sum does not depend on the ``lmax`` it was projected with);
    ``projected``: the views projected at ``samples`` to ``lmax``, likewise.
    """

    def __init__(self, brdf, lmax: int, samples: int, views=None, energy=None, reference=None,
                 projected=None):  # fmt: skip
        self.brdf, self.lmax, self.sample_count = brdf, lmax, samples
        self.views = probe_views() if views is None else views
        energy = product_energy(brdf, self.views, 256) if energy is None else energy
        self.energy = energy.sum(axis=1)
        if reference is None:
            reference, _ = project_views(brdf, self.views, lmax, samples=REFERENCE_SAMPLES)
        ref = reference[:, : n_coeffs(lmax)]
        if projected is None:
            projected, _ = project_views(brdf, self.views, lmax, samples=samples)
        self.projected = projected
        lost = np.clip(self.energy - np.sum(ref * ref, axis=(1, 2)), 0, None)
        self.truncation = mean_relative_norm(lost, self.energy)
        self.samples = mean_relative_norm(np.sum((self.projected - ref) ** 2, axis=(1, 2)),
                                          self.energy)  # fmt: skip

    def at(self, size: int) -> dict:
        """``truncation``, ``samples``, ``lookup`` and their ``total`` for a ``size²`` table."""
        table, _ = tabulate(self.brdf, self.lmax, (size, size), samples=self.sample_count)
        diff = fetch(table, self.views) - self.projected
        look = mean_relative_norm(np.sum(diff**2, axis=(1, 2)), self.energy)
        total = float(np.sqrt(self.truncation**2 + self.samples**2 + look**2))
        return {"truncation": self.truncation, "samples": self.samples, "lookup": look,
                "total": total}  # fmt: skip


LMAX_SHARE = 0.6
"""Share of a ``brdf_table``'s tolerance its truncation at the planned lmax may take (the
rest is left to the samples and the look-up; :func:`table_lmax`)."""


def table_lmax(truncation, tol: float) -> int:
    """The planner's ``brdf_table`` lmax: the smallest of :data:`TABLE_LMAX` whose truncation
    error ``truncation(L)`` (a relative error, :class:`TableErrors`) is at most
    :data:`LMAX_SHARE` of ``tol``, else the largest. ``truncation`` is called in that order,
    and no further than the lmax it returns."""
    return next((L for L in TABLE_LMAX if truncation(L) <= LMAX_SHARE * tol), TABLE_LMAX[-1])


@path_arguments("merl")
def plan_brdf_table(model: str, params: dict, merl: str | None, tol: float) -> dict:
    """Cheapest ``(lmax, size, samples)`` whose predicted error meets ``tol`` (greedy: lmax for
    :data:`LMAX_SHARE` of it, :func:`table_lmax`, then samples, then the smallest size meeting
    the whole)."""
    brdf, t_make = _timed(make_brdf, model, merl_path=merl, **param_strings(params))
    views = probe_views()
    energy = product_energy(brdf, views, 256)
    total = energy.sum(axis=1)
    ref, _ = project_views(brdf, views, max(TABLE_LMAX), samples=REFERENCE_SAMPLES)

    def truncation(L):
        kept = np.sum(ref[:, : n_coeffs(L)] ** 2, axis=(1, 2))
        return mean_relative_norm(np.clip(total - kept, 0, None), total)

    lmax = table_lmax(truncation, tol)
    for samples in TABLE_SAMPLES:  # the last one if none meets 40 % of tol
        got, _ = project_views(brdf, views, lmax, samples=samples)
        noise = np.sum((got - ref[:, : n_coeffs(lmax)]) ** 2, axis=(1, 2))
        if mean_relative_norm(noise, total) <= 0.4 * tol:
            break
    t8 = warm_seconds("brdf_table", tabulate, brdf, lmax, (8, 8), samples=samples)
    errors = TableErrors(brdf, lmax, samples, views, energy, ref, projected=got)
    sizes = TABLE_SIZES
    if np.hypot(errors.truncation, errors.samples) > tol:
        sizes = TABLE_SIZES[-1:]  # no size meets it: only the best one's error is reported
    for size in sizes:
        errs = errors.at(size)
        if errs["total"] <= tol:
            break
    out = {
        "settings": {"model": model, "params": params, "merl": merl, "lmax": lmax,
                     "size": size, "samples": samples},  # fmt: skip
        "predicted_error": {"brdf_table": errs["total"]},
        "work_seconds": t_make + t8 * (size / 8) ** 2,
        "bytes": size * size * n_coeffs(lmax) * 3 * 8,
        "note": "error: truncation {truncation:.3g}, samples {samples:.3g}, look-up {lookup:.3g}"
        .format(**errs),
    }
    if errs["total"] > tol:
        out["impossible"] = {"brdf_table": errs["total"]}
    return out


def plan_shexp(env: EnvMap, lo: float, hi: float, tol: float) -> dict:
    """An SH-exp probe over perceptual roughness ``[lo, hi]`` (α = r²): the default fit
    (:class:`~shbake.bakers.shexp.FitConfig`: two sets, lmax 5/2, the ``α`` weight; one set
    and one α sample for a single roughness), the one the dielectric limit
    :data:`SHEXP_DIELECTRIC_ALPHA` was measured with, of the map itself — the bake's fit, with
    the plan it loads (built here once per machine into the plan cache) — whose RMS log
    residual is the error; the probe is kept in the unit (``fit``,
    :meth:`~shbake.bakers.shexp.ShexpProbe.to_record`) for the bake to write
    (:func:`shbake.batch.scene_bake.bake_scene`). The time: that fit, once per map shape and
    configuration (:func:`~shbake.batch.plan_costs.shape_seconds`)."""
    from shbake.batch.probe_jobs import fit_plan, shared_dfg_table

    a_lo, a_hi = ggx_alpha(lo), ggx_alpha(hi)
    single = {} if a_hi > a_lo else {"sets": 1, "alpha_count": 1}
    config = FitConfig(alpha_min=a_lo, alpha_max=a_hi, **single)
    plan = fit_plan(config, env.shape)
    probe = plan.fit_many([env.pixels])[0]  # the call the bake makes: the same bits
    shared_dfg_table()
    t_fit = shape_seconds("shexp", (config, env.shape), plan.fit, env.pixels)
    return {
        "settings": {"fit": config.as_dict()},
        "predicted_error": {"glossy_probe": float(probe.stats["log_rms"])},
        "work_seconds": t_fit,
        "bytes": 12 * config.sets * config.n_params,
        "note": "error: the fit's RMS log residual (the bake writes this fit)",
        "fit": probe.to_record(),
    }


def plan_shrm(env: EnvMap, model: str, params: dict, tol: float) -> dict:
    """An SHRM (Ramamoorthi & Hanrahan 2002) of an isotropic BRDF: the smallest ``F``, ``P``
    whose truncation leaves at most ``tol`` of the BRDF's energy out
    (:func:`shbake.brdf.reflection.search_orders`: ``select_orders`` on coefficients to
    ``F_LIMIT``, ``P_LIMIT``, RH02 §5.1 and appendix C), the face size from ``F``
    (:func:`~shbake.bakers.shrm.auto_face_size`).

    ``impossible`` when no ``F ≤ 64``, ``P ≤ 16`` reaches ``tol`` (e.g. GGX at low roughness).
    Time: the BRDF coefficients at ``(F, P)`` and the lighting projection as the bake computes
    them, the cube at half the face size scaled by texel count.
    """
    from shbake.bakers.shrm import auto_face_size, shrm_cube
    from shbake.brdf.reflection import brdf_coefficients, make_reflection_brdf, search_orders

    rb = make_reflection_brdf(model, param_strings(params))
    orders, _ = search_orders(rb, tol)
    if not orders.reached:
        return {"impossible": {"shrm": orders.eps_brdf}}
    F, P = orders.F, orders.P
    size = auto_face_size(F)
    t_coeffs = warm_seconds("shrm_coeffs", brdf_coefficients, rb, F, P)
    co = brdf_coefficients(rb, F, P)
    L, t_light = _timed(env.project, F)
    half = max(4, size // 2)
    t_cube = warm_seconds("shrm_cube", shrm_cube, L, co, half, rb.kind)
    terms = P + 1 if rb.kind == "tangent" else (P + 1) ** 2
    return {
        "settings": {"brdf": model, "params": params, "merl": None, "eps": tol, "F": F,
                     "P": P, "face_size": size},  # fmt: skip
        "predicted_error": {"shrm": float(orders.eps_brdf)},
        "work_seconds": t_coeffs + t_light + t_cube * (size / half) ** 2,
        "bytes": 6 * size * size * terms * 3 * 4,
        "note": "error: BRDF energy left out by F, P (RH02 5.1)",
    }


def plan_splitsum(env: EnvMap, lo: float, hi: float) -> dict:
    """A split-sum probe covering perceptual roughness ``[lo, hi]`` (4 levels, α = r²
    evenly spaced); no error model (module docstring).

    Time: the chain prefiltered at half the size, scaled by texel count (once per map shape
    and configuration, :func:`~shbake.batch.plan_costs.shape_seconds`).
    """
    from shbake.bakers.splitsum import prefilter_chain
    from shbake.batch.probe_jobs import shared_dfg_table

    shared_dfg_table()  # the bake's DFG table, now in the plan cache
    a_lo = max(ggx_alpha(lo), 1e-3)
    a_hi = max(ggx_alpha(hi), a_lo + 0.01)
    alphas = tuple(float(a) for a in np.linspace(a_lo, min(a_hi, 1.0), 4))
    config = SplitSumConfig(top=64, min_size=16, alphas=alphas, samples=256)
    small = SplitSumConfig(**(config.as_dict() | {"top": 32, "min_size": 8}))
    t = shape_seconds("splitsum", (small, env.shape), prefilter_chain, env.pixels, small)
    texels = sum(s * s for s in config.sizes)
    return {
        "settings": {"splitsum": config.as_dict()},
        "predicted_error": {},
        "work_seconds": t * texels / sum(s * s for s in small.sizes),
        "bytes": 12 * texels,
        "note": "split-sum: no error model (approximation, not quadrature); tolerance not checked",
    }


def recipe_classes(scene: Scene) -> set[str]:
    """The recipe classes (:mod:`shbake.batch.plan_costs`) a plan of ``scene`` may use."""
    kinds = {m.kind for m in scene.materials}
    out = set()
    if kinds & {"diffuse", "fibre"}:
        out |= {"env_sh"} | {f"export:{t}" for t in scene.exports}
    if kinds & {"anisotropic", "measured"}:
        out.add("brdf_table")
    for m in scene.materials:
        if m.kind == "glossy":
            out |= {"shrm"} if m.model != "ggx" else {"shexp", "splitsum", "shrm"}
    return out


def plan_scene(scene: Scene, cache: dict | None = None) -> dict:
    """The plan of ``scene``: ``{"assets": [...], "materials": {...}}``.

    ``cache``: earlier per-unit plans keyed by their inputs (the lock's
    ``plans``); a unit whose key is there is not re-measured. Predicted seconds
    are the recipe's fixed CPU cost (:func:`~shbake.batch.plan_costs.recipe_overheads`)
    plus the unit's measured work.
    """
    cache = {} if cache is None else cache
    overhead = recipe_overheads(recipe_classes(scene))
    kinds = {m.kind for m in scene.materials}
    glossy = [m for m in scene.materials if m.kind == "glossy" and m.model == "ggx"]
    reflective = [m for m in scene.materials if m.kind == "glossy" and m.model != "ggx"]
    assets = []
    used = {m.name: [] for m in scene.materials}

    def add(aid, kind, p, inputs, hashes, key, tolerances, env=None, cls=None):
        a = _asset(aid, kind, scene, p, inputs, hashes, key, tolerances, env)
        a["predicted_seconds"] = overhead[cls or kind] + p["work_seconds"]
        assets.append(a)
        return a

    for env in scene.environments:
        digest = file_hash(env.map)
        needs_sh = kinds & {"diffuse", "fibre"}
        env_map = None
        load_s = 0.0

        def get_env(path=env.map, with_load=False):
            nonlocal env_map, load_s
            if env_map is None:
                env_map, load_s = _timed(load_environment, path, quiet=True)
                if "load" not in WARMED:  # the first load also pays imports: time it again
                    WARMED.add("load")
                    env_map, load_s = _timed(load_environment, path, quiet=True)
            return (env_map, load_s) if with_load else env_map

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
                cache[key]["load_seconds"] = load_s
            p = cache[key]
            if "impossible" in p:
                k = next(iter(p["impossible"]))
                tol, tkey = irr if k == "irradiance" else tan
                raise scene.error(tkey, f"impossible tolerance {tol:g} for {env.name}: lmax "
                                  f"{MAX_IRRADIANCE_LMAX} reaches {p['impossible'][k]:.3g}")
            aid = f"env_sh/{env.name}"
            tols = {k: v for k, v in (("irradiance", irr), ("tangent_irradiance", tan)) if v}
            env_sh = add(aid, "env_sh", p, [env.map], {"map": digest}, key, tols, env)
            for m in scene.materials:
                if m.kind in ("diffuse", "fibre"):
                    used[m.name].append(aid)
            for target in sorted(exports):
                if irr is None:
                    raise scene.error("scene.exports", "engine exports need a diffuse material "
                                      "(they carry the irradiance SH)")  # fmt: skip
                from shbake.format.exports import target_module

                cube = target_module(target).CUBES is not None
                work = p["load_seconds"] + (p.get("sun_seconds", 0.0) if cube else 0.0)
                assets.append({
                    "id": f"export/{target}/{env.name}", "kind": "export",
                    "output": asset_output(scene.out_dir, f"export/{target}/{env.name}"),
                    "inputs": [env.map, env_sh["output"]], "input_hashes": {"map": digest},
                    "plan_key": _digest(["export", PLAN_VERSION, key, target]),
                    "settings": {"target": target, "env_sh": aid},
                    "tolerances": {}, "predicted_error": {},
                    "predicted_seconds": overhead[f"export:{target}"] + work,
                    "bytes": None, "note": "engine export: no error model",
                })  # fmt: skip
        if glossy:
            tol, tkey = scene.tolerance("glossy_probe", env)
            low_dielectrics = [m for m in glossy if ggx_alpha(m.roughness[0]) >= SHEXP_MIN_ALPHA
                          and ggx_alpha(m.roughness[0]) < SHEXP_DIELECTRIC_ALPHA
                          and float(m.params.get("F0", 1.0)) < SHEXP_DIELECTRIC_F0]  # fmt: skip
            high = [m for m in glossy if ggx_alpha(m.roughness[0]) >= SHEXP_MIN_ALPHA
                    and m not in low_dielectrics]  # fmt: skip
            low = [m for m in glossy if ggx_alpha(m.roughness[0]) < SHEXP_MIN_ALPHA]
            low += low_dielectrics
            missed = None  # the SH-exp fit's predicted error when it misses the tolerance
            if high:
                lo = min(m.roughness[0] for m in high)
                hi = max(m.roughness[1] for m in high)
                key = _digest(["shexp", PLAN_VERSION, digest, lo, hi, tol])
                if key not in cache:
                    cache[key] = plan_shexp(get_env(), lo, hi, tol)
                    cache[key]["work_seconds"] += load_s
                p = cache[key]
                if p["predicted_error"]["glossy_probe"] <= tol:
                    aid = f"shexp/{env.name}"
                    add(aid, "shexp", p, [env.map], {"map": digest}, key,
                        {"glossy_probe": (tol, tkey)}, env)  # fmt: skip
                    for m in high:
                        used[m.name].append(aid)
                else:
                    low += high
                    missed = ([m.name for m in high], p["predicted_error"]["glossy_probe"])
            # one GGX roughness the probe misses: an SHRM of GGX at that width and the
            # material's F0 (the SHRM bakes the whole BRDF, Schlick Fresnel included; the
            # probes leave F0 to shading) when its orders meet `shrm`
            for m in [m for m in low if m.roughness[0] == m.roughness[1]]:
                alpha = max(ggx_alpha(m.roughness[0]), 1e-4)
                terms = [("", {"alpha": alpha, **m.params})]
                aids = _plan_shrm_asset(scene, env, m, "ggx", terms, digest, get_env, cache,
                                        assets, add, optional=True)  # fmt: skip
                if aids:
                    used[m.name] += aids
                    low.remove(m)
            if low:
                lo = min(m.roughness[0] for m in low)
                hi = max(m.roughness[1] for m in low)
                key = _digest(["splitsum", PLAN_VERSION, digest, lo, hi])
                if key not in cache:
                    cache[key] = plan_splitsum(get_env(), lo, hi)
                    cache[key]["work_seconds"] += load_s
                aid = f"splitsum/{env.name}"
                why = [m.name for m in low_dielectrics if m in low]
                note = cache[key]["note"]
                if why:
                    note += (f"; {', '.join(why)}: dielectric below α {SHEXP_DIELECTRIC_ALPHA:g}, "
                             "where SH-exp loses to split-sum in more than 10 % of the "
                             "shared-map cases")  # fmt: skip
                fitted = [m.name for m in low if missed is not None and m.name in missed[0]]
                if fitted:
                    note += (f"; {', '.join(fitted)}: the SH-exp fit misses glossy_probe (its "
                             f"RMS log residual {missed[1]:.3g} > {tol:g})")  # fmt: skip
                p = cache[key] | {"note": note}
                add(aid, "splitsum", p, [env.map], {"map": digest}, key, {}, env)
                for m in low:
                    used[m.name].append(aid)
        for m in reflective:
            used[m.name] += _plan_shrm_asset(scene, env, m, m.model, [("", m.params)], digest,
                                             get_env, cache, assets, add)  # fmt: skip
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
            add(aid, "brdf_table", p, inputs, {}, key, {"brdf_table": (tol, tkey)})
            tables[sid] = aid
        used[m.name].append(tables[sid])
    return {"scene": scene.path, "name": scene.name, "out_dir": scene.out_dir,
            "assets": assets, "materials": used}  # fmt: skip


PLAN_TASK_MAPS = 8
"""Maps a worker plans per task (:func:`plan_scene_kept` with ``jobs``)."""
PLAN_POOL_MAPS = 64
"""Fewest maps planned in workers: a worker's start (imports, numba's cache, its first
call of each kind) costs seconds, about what 10-20 maps' plans do (24 maps on 2 cores:
12 s in one process, 28 s with two workers)."""


def _plan_task(scene: Scene, cache: dict) -> dict:
    """A worker's plan of a few maps of a scene: the units it measured. A unit that fails
    (an impossible tolerance) is left to the main pass, which raises its error."""
    from shbake.errors import ShbakeError

    units = dict(cache)
    try:
        plan_scene(scene, cache=units)
    except ShbakeError:
        pass
    return {k: v for k, v in units.items() if k not in cache}


def _plan_in_workers(scene: Scene, units: dict, jobs: int) -> None:
    """Measure the per-map units of ``scene`` in ``jobs`` worker processes,
    :data:`PLAN_TASK_MAPS` distinct maps a task (:func:`_distinct_contents`), into ``units``
    (the main pass then finds them all); nothing below :data:`PLAN_POOL_MAPS` maps or when
    ``units`` already holds about one per map (a re-plan after a few changed maps does its
    few here)."""
    from dataclasses import replace

    from shbake.batch.workers import start_server, worker_pool

    if jobs <= 1 or len(scene.environments) < PLAN_POOL_MAPS:
        return
    if len(units) < len(scene.environments):
        start_server()  # it warms while the maps are hashed, in case they need the pool
    envs = _distinct_contents(scene.environments)
    if len(envs) < PLAN_POOL_MAPS or len(units) >= len(envs):
        return
    recipe_overheads(recipe_classes(scene))  # measured here once, before workers read it
    per_map = tuple(m for m in scene.materials if m.kind not in ("anisotropic", "measured"))
    tasks = [replace(scene, environments=envs[i : i + PLAN_TASK_MAPS], materials=per_map)
             for i in range(0, len(envs), PLAN_TASK_MAPS)]  # fmt: skip
    known = dict(units)
    with worker_pool(jobs) as pool:
        for measured in pool.map(_plan_task, tasks, [known] * len(tasks)):
            units.update(measured)


def _distinct_contents(envs) -> list:
    """One probe of ``envs`` per map content and per-probe tolerances, in order: the units
    of probes that share both are the same (their keys name the map's bytes, not its path),
    so copies of a map or links to it are measured once, not once per task they fall in."""
    first: dict = {}
    for e in envs:
        tolerances = json.dumps(e.tolerances, sort_keys=True, default=str)
        first.setdefault((file_hash(e.map), tolerances), e)
    return list(first.values())


def plan_scene_kept(scene: Scene, cache: dict | None = None, jobs: int = 1) -> dict:
    """:func:`plan_scene` with the per-unit plans the last plan of this scene measured
    (:func:`shbake.batch.plan_cache.scene_units`; ``cache`` — the lock's — first), keeping
    the units it used there for the next: ``shbake plan`` then ``shbake bake`` from a cold
    output folder measures each unit once, not twice. ``jobs``: the maps' units measured
    in that many worker processes first (:func:`_plan_in_workers`)."""
    from shbake.batch.plan_cache import scene_units, store_scene_units

    kept = scene_units(scene.path)
    units = _Consulted(kept | (cache if cache is not None else {}))
    _plan_in_workers(scene, units, jobs)
    plan = plan_scene(scene, cache=units)
    used = {k: units[k] for k in sorted(units.read)}
    if cache is not None:  # the units this plan read: what the lock keeps
        cache.clear()
        cache.update(used)
    if used != kept:
        store_scene_units(scene.path, used)
    return plan


class _Consulted(dict):
    """Per-unit plans that remember which keys a plan read (``read``): the units it used,
    an SH-exp fit that missed its tolerance (and so has no asset) included."""

    def __init__(self, *a):
        super().__init__(*a)
        self.read: set = set()

    def __getitem__(self, key):
        self.read.add(key)
        return super().__getitem__(key)


def _plan_shrm_asset(scene, env, m, model, terms, digest, get_env, cache, assets, add,
                     optional=False) -> list[str] | None:  # fmt: skip
    """Plan ``m``'s SHRMs on ``env``, one per ``(id suffix, params)`` of ``terms`` (an asset
    is shared by materials with the same BRDF); their asset ids, or ``None`` when
    ``optional`` and some term's orders cannot meet the ``shrm`` tolerance."""
    tol, tkey = scene.tolerance("shrm", env)
    units = []
    for suffix, params in terms:
        key = _digest(["shrm", PLAN_VERSION, digest, model, params, tol])
        if key not in cache:
            env_map, load_s = get_env(with_load=True)
            cache[key] = plan_shrm(env_map, model, params, tol)
            if "work_seconds" in cache[key]:
                cache[key]["work_seconds"] += load_s
        p = cache[key]
        if "impossible" in p:
            if optional:
                return None
            left = p["impossible"]["shrm"]
            raise scene.error(tkey, f"impossible tolerance {tol:g} for {m.name} on {env.name}: "
                              f"F {F_LIMIT}, P {P_LIMIT} leave {left:.3g} of the BRDF energy out")
        units.append((f"shrm/{m.name}{suffix}/{env.name}", key, p))
    aids = []
    for aid, key, p in units:
        shared = [a["id"] for a in assets
                  if (a["kind"], a["plan_key"], a["id"].split("/")[-1]) == ("shrm", key, env.name)]
        if not shared:
            add(aid, "shrm", p, [env.map], {"map": digest}, key, {"shrm": (tol, tkey)}, env)
        aids.append(shared[0] if shared else aid)
    return aids


def _asset(aid, kind, scene, p, inputs, hashes, key, tolerances, env=None) -> dict:
    settings = dict(p["settings"])
    if env is not None:  # where the probe sits and how its environment is turned (probe_pose)
        settings["pose"] = {"position": list(env.position), "rotation_deg": env.rotation_deg}
    return {
        "id": aid,
        "kind": kind,
        "output": asset_output(scene.out_dir, aid),
        "inputs": inputs,
        "input_hashes": hashes,
        "plan_key": key,
        "settings": settings,
        "tolerances": {k: v[0] for k, v in tolerances.items()},
        "predicted_error": p["predicted_error"],
        "predicted_seconds": None,
        "bytes": p["bytes"],
        "note": p["note"],
    }


def format_plan(plan: dict) -> str:
    """The plan as a text table: asset, settings, predicted error (tolerance), time, bytes."""
    rows = [("asset", "settings", "pred. error (tol)", "pred. s", "bytes")]
    for a in plan["assets"]:
        s = a["settings"]
        if a["kind"] == "env_sh":
            text = f"lmax {s['lmax']}" + (" +sun" if s["extract_sun"] else "")
            text += f" +{s['lights']} lights" if s.get("lights") is not None else ""
        elif a["kind"] == "brdf_table":
            text = f"lmax {s['lmax']} size {s['size']} samples {s['samples']}"
        elif a["kind"] == "shexp":
            f = s["fit"]
            text = (f"P{f['lmax_p']} Q{f['lmax_q']} a {f['alpha_min']:.3g}-"
                    f"{f['alpha_max']:.3g} samples {f['samples']}")  # fmt: skip
        elif a["kind"] == "shrm":
            text = f"{s['brdf']} F {s['F']} P {s['P']} face {s['face_size']}"
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


__all__ = ["plan_scene", "plan_scene_kept", "format_plan", "file_hash", "asdict"]
