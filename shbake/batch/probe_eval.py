"""``probe-eval``: bake every probe under test for a map and measure them against ground truth.

Probes under test (:data:`EVALUATED`): SH-exp v2 (the default fit), the
paper's SH-exp (:meth:`FitConfig.paper`), the paper's plain split-sum
(1024 samples per texel, levels at the evaluated ``α``), the engine-grade
split-sum (filtered importance sampling, same levels) and the GGX SHRM
(Ramamoorthi & Hanrahan 2002; :class:`ShrmProbe`): an ``E0`` and an ``E1``
SHRM per evaluated ``α``, baked by :func:`shbake.bakers.shrm.bake_shrm` (the
``shrm`` command's baker) with orders from a tolerance ``ε``. A probe that
does not cover a case's ``α`` (SH-exp is fitted on ``α ≥ 0.2``) has no MSE
there (``None``, "n/a" in the report): nothing is extrapolated.

Each probe's bake is timed per map (wall seconds, :func:`time.perf_counter`;
:func:`evaluate_map`): the error and the time of every technique are reported together.
"""

import functools
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
from shbake.conventions import ggx_alpha, perceptual_roughness
from shbake.errors import ParameterError
from shbake.evaluation.probes import ALPHAS, MATERIALS, VIEW_YAWS, evaluate_cases
from shbake.format.probe import probe_bytes
from shbake.format.shexp import build_shexp_asset
from shbake.format.splitsum import build_splitsum_asset
from shbake.resources import path_arguments

EVALUATED = ("shexp_v2", "shexp_paper", "splitsum_plain", "splitsum_filtered", "shrm")
SHRM_EPS = 0.01
"""Default tolerance of the GGX SHRM in ``probe-eval`` (issue 13: ε = 0.01)."""
SHRM_FACE_SIZE = 64
"""Default cube face size of the GGX SHRM in ``probe-eval`` (the automatic ``≈ 5F`` would be
256 at the capped ``F = 64``: 1.4 GB per cube at ``P = 16``)."""


@functools.lru_cache(maxsize=32)
def ggx_shrm_coefficients(alpha: float, f0: float):
    """``ρ̂_lpq`` of GGX (``α``, Schlick ``F0``; separable Smith G, SPEC §4) to the baker's caps
    ``F ≤ 64``, ``P ≤ 16``, once per process (they do not depend on the map)."""
    from shbake.brdf.reflection import F_LIMIT, P_LIMIT, brdf_coefficients, make_reflection_brdf

    rb = make_reflection_brdf("ggx", {"alpha": float(alpha), "F0": float(f0)})
    return rb, brdf_coefficients(rb, F_LIMIT, P_LIMIT)


def shrm_orders(alphas, eps: float) -> list[dict]:
    """The orders the baker's rule (:func:`shbake.brdf.reflection.select_orders`) picks for the
    ``E0`` (``F0 = 1``) and ``E1`` (``F0 = 0``) SHRM of every ``α``: per ``α`` a dict with
    ``alpha``, ``roughness`` and, for ``E0``/``E1``, ``F``, ``P``, ``captured`` (the BRDF
    energy fraction kept) and ``reached`` (False: ``1 − ε`` is not reachable within
    ``F ≤ 64``, ``P ≤ 16``; the capped orders are used and reported)."""
    from shbake.brdf.reflection import select_orders

    out = []
    for a in alphas:
        row = {"alpha": float(a), "roughness": perceptual_roughness(float(a))}
        for term, f0 in (("E0", 1.0), ("E1", 0.0)):
            o = select_orders(ggx_shrm_coefficients(float(a), f0)[1], eps)
            row[term] = {"F": o.F, "P": o.P, "captured": 1.0 - o.eps_brdf, "reached": o.reached}
        out.append(row)
    return out


def shrm_cube_bytes(face_size: int, P: int) -> int:
    """Bytes of one float32 SHRM cube ``(6, S, S, (P+1)², 3)``."""
    return 6 * face_size * face_size * (P + 1) ** 2 * 3 * 4


@dataclass
class ShrmProbe:
    """The GGX SHRM probe of one map: ``E0``/``E1`` SHRMs at every ``α`` of ``orders``
    (:func:`shrm_orders`), ``face_size`` texels per face; shaded by
    :func:`shbake.shading.shrm.evaluate_ggx_shrm` (per-pixel eq. 7, ``F0 E0 + (1 − F0) E1``).

    The SHRMs of one ``α`` are baked when a case first needs them and dropped when the next
    ``α`` comes (at the capped orders one cube is 85 MB at ``S = 64``). ``seconds``: wall
    seconds spent in :func:`~shbake.bakers.shrm.bake_shrm` so far, summed over its ``bakes``
    calls (a re-bake of an ``α`` that was dropped counts again)."""

    env: object
    orders: list
    face_size: int
    eps: float
    seconds: float = 0.0
    bakes: int = 0
    _held: tuple = field(default=(None, None), repr=False)

    def _level(self, alpha: float):
        for row in self.orders:
            if abs(row["alpha"] - alpha) <= 1e-9:
                return row
        return None

    def covers(self, alpha=None, **material) -> bool:
        return self._level(float(alpha)) is not None

    @property
    def nbytes(self) -> int:
        """Bytes per probe: both cubes of every ``α`` (float32)."""
        return sum(shrm_cube_bytes(self.face_size, row[t]["P"]) for row in self.orders
                   for t in ("E0", "E1"))  # fmt: skip

    def cubes(self, alpha: float):
        from shbake.bakers.shrm import bake_shrm

        row = self._level(float(alpha))
        if row is None:
            raise ParameterError(f"alpha {alpha:g} is not one of the SHRM's baked widths")
        if self._held[0] != row["alpha"]:
            self._held = (None, None)
            cubes = []
            for term, f0 in (("E0", 1.0), ("E1", 0.0)):
                rb, co = ggx_shrm_coefficients(row["alpha"], f0)
                o = row[term]
                t0 = time.perf_counter()
                cubes.append(bake_shrm(self.env, rb, self.eps, o["F"], o["P"], self.face_size,
                                       coeffs_full=co).cube)  # fmt: skip
                self.seconds += time.perf_counter() - t0
                self.bakes += 1
            self._held = (row["alpha"], tuple(cubes))
        return self._held[1]

    def shade(self, normals, views, alpha=None, f0=1.0):
        """The shader protocol's ``shade``: the registry's ``ggx-shrm`` shader
        (:class:`~shbake.shading.shrm.GgxShrmShader`) of this ``α``'s cubes (baked on
        first use)."""
        from shbake.shading.shader import shader_class

        c0, c1 = self.cubes(alpha)
        ggx = shader_class("ggx-shrm")([(float(alpha), c0, c1)])
        return ggx.shade(normals, views, alpha, f0)


def split_levels(alphas) -> tuple:
    """Split-sum levels at exactly the evaluated widths (at least two: ``α = 1`` added, or
    ``0.25`` when only ``α = 1`` is evaluated)."""
    a = sorted({float(x) for x in alphas})
    if len(a) < 2:
        a = sorted(set(a) | {1.0 if a[0] < 1.0 else 0.25})
    return tuple(a)


def bake_probes(env, plans: dict, split_config: SplitSumConfig, dfg, shrm: dict | None = None,
                alphas=ALPHAS) -> tuple[dict, dict]:  # fmt: skip
    """The probe assets of one loaded map and the wall seconds each took to bake:
    ``(assets, seconds)``, both keyed by probe name. ``plans`` name → :class:`FitPlan` for
    the SH-exp probes; both split-sum prefilters of ``split_config``; the :class:`ShrmProbe`
    when ``shrm`` (``{"eps", "face_size", "orders"}``) is given. SH-exp probes are not fitted
    when no ``α`` of ``alphas`` lies in their range.

    ``seconds`` counts, per SH-exp probe, ``plan.fit`` and its asset (not the plan, which is
    built once per config and map shape before: ``fit_plan``); per split-sum, its prefiltered
    chain and asset; the shared DFG table is not counted. The SHRM bakes its cubes lazily
    (:meth:`ShrmProbe.cubes`), so it is not in ``seconds``: read ``assets["shrm"].seconds``
    after shading (:func:`evaluate_map` does)."""
    assets, seconds = {}, {}
    for name, plan in plans.items():
        if any(plan.config.alpha_min - 1e-9 <= a <= plan.config.alpha_max + 1e-9 for a in alphas):
            t0 = time.perf_counter()
            assets[name] = build_shexp_asset(plan.fit(env.pixels), plan.config, dfg, env.meta)
            seconds[name] = time.perf_counter() - t0
    for prefilter in ("plain", "filtered"):
        name = f"splitsum_{prefilter}"
        t0 = time.perf_counter()
        cfg = replace(split_config, prefilter=prefilter)
        chain = prefilter_chain(env.pixels, cfg)
        assets[name] = build_splitsum_asset(chain, cfg, dfg, env.meta)
        seconds[name] = time.perf_counter() - t0
    if shrm is not None:
        assets["shrm"] = ShrmProbe(env, shrm["orders"], shrm["face_size"], shrm["eps"])
    return assets, seconds


def evaluate_map(env, plans: dict, split_config: SplitSumConfig, dfg, size: int = 32,
                 truth_samples: int = 4096, alphas=ALPHAS, yaws=VIEW_YAWS,
                 materials=MATERIALS, cache_dir=None, sheet_dir=None, label="map",
                 shrm: dict | None = None):  # fmt: skip
    """Every case of one loaded map: ``(rows, assets, nbytes, seconds)``: the rows
    (:func:`evaluate_cases`), the assets, their bytes per probe and the wall seconds each
    probe took to bake on this map (:func:`bake_probes`; the SHRM: the seconds of all its
    :func:`~shbake.bakers.shrm.bake_shrm` calls while the cases were shaded,
    :attr:`ShrmProbe.seconds`; neither the plans, the ground truth nor the shading are
    counted). ``sheet_dir``: one contact sheet per case, named after ``label``."""
    assets, seconds = bake_probes(env, plans, split_config, dfg, shrm, alphas)
    rows = evaluate_cases(env.pixels, assets, size, truth_samples, alphas, yaws, materials,
                          cache_dir, sheet_dir, label)  # fmt: skip
    nbytes = {name: (a.nbytes if isinstance(a, ShrmProbe) else probe_bytes(a))
              for name, a in assets.items()}  # fmt: skip
    if isinstance(assets.get("shrm"), ShrmProbe):
        seconds["shrm"] = assets["shrm"].seconds
    return rows, assets, nbytes, seconds


ROUGHNESS_MIN = 0.1
"""Smallest perceptual roughness of an evaluated case."""


def evaluation_alphas(roughness=None) -> tuple:
    """GGX widths ``α = r²`` of the cases: the paper's six (:data:`ALPHAS`) by default, else
    those of the perceptual ``roughness`` values (each in ``[ROUGHNESS_MIN, 1]``), sorted,
    once each."""
    if roughness is None or len(roughness) == 0:
        return ALPHAS
    out = set()
    for r in roughness:
        r = float(r)
        if not (np.isfinite(r) and ROUGHNESS_MIN <= r <= 1.0):
            raise ParameterError(f"roughness {r:g} is outside [{ROUGHNESS_MIN:g}, 1] "
                                 "(perceptual, α = r²)")  # fmt: skip
        out.add(round(ggx_alpha(r), 6))
    return tuple(sorted(out))


def check_evaluation(
    roughness=None, shrm_eps: float | None = SHRM_EPS, shrm_face_size: int = SHRM_FACE_SIZE
) -> tuple[tuple, dict | None]:
    """The settings of :func:`evaluate_maps` checked before any map is read (a
    :class:`~shbake.errors.ParameterError` names the first bad one): the cases' ``α``
    (:func:`evaluation_alphas`) and the GGX SHRM's settings (``None``: no SHRM)."""
    from shbake.bakers.shrm import check_face_size
    from shbake.brdf.reflection import F_LIMIT, P_LIMIT, check_eps

    alphas = evaluation_alphas(roughness)
    if shrm_eps is None:
        return alphas, None
    eps = check_eps(shrm_eps)
    check_face_size(shrm_face_size, P_LIMIT, "surface")
    return alphas, {"eps": eps, "face_size": int(shrm_face_size), "F_limit": F_LIMIT,
                    "P_limit": P_LIMIT}  # fmt: skip


@path_arguments("paths", "cache_dir", "sheet_dir")
def evaluate_maps(paths, size: int = 32, truth_samples: int = 4096, progress=None,
                  cache_dir=None, sheet_dir=None, roughness=None, shrm_eps: float | None = SHRM_EPS,
                  shrm_face_size: int = SHRM_FACE_SIZE, yaws=VIEW_YAWS) -> dict:  # fmt: skip
    """Every case of every map (lat-long files): ``{"maps": {stem: rows}, "bytes": {name:
    bytes per probe}, "seconds": {stem: {name: bake seconds}}, "configs": …, "alphas": …,
    "shrm": …}`` (``seconds``: wall seconds each probe took to bake on that map,
    :func:`evaluate_map`; the SH-exp fit plans are built before and not counted, and the
    first map's seconds may include numba compiling a kernel); SH-exp v2 is
    :class:`FitConfig` ``()``, the paper's fit :meth:`FitConfig.paper`, both split-sums
    :class:`SplitSumConfig` with levels at the evaluated ``α``
    (:func:`split_levels`; the default levels for the paper's six), the GGX SHRM at
    ``shrm_eps`` (``None``: no SHRM) and ``shrm_face_size`` (:class:`ShrmProbe`; its orders,
    captured energy and whether ``1 − ε`` was reached under ``"shrm"``). ``roughness``:
    perceptual roughness values of the cases (:func:`evaluation_alphas`); ``yaws``: the views'
    yaws in degrees (default the paper's four, :data:`VIEW_YAWS`)."""
    from shbake.bakers.shexp import FitConfig
    from shbake.batch.probe_jobs import fit_plan, shared_dfg_table
    from shbake.envmap import load_environment
    from shbake.errors import InputError
    from shbake.format.atomic import check_output_dir, makedirs

    if sheet_dir is not None:
        check_output_dir(sheet_dir, "--sheet-dir")
    alphas, shrm = check_evaluation(roughness, shrm_eps, shrm_face_size)
    yaws = tuple(float(y) for y in yaws)
    if not yaws or not all(np.isfinite(y) for y in yaws):
        raise ParameterError("view yaws must be finite degrees, at least one")
    if shrm is not None:
        shrm["orders"] = shrm_orders(alphas, shrm["eps"])
    dfg = shared_dfg_table()
    split = SplitSumConfig(alphas=split_levels(alphas))
    configs = {"shexp_v2": FitConfig(), "shexp_paper": FitConfig.paper()}
    out = {"maps": {}, "bytes": {}, "seconds": {}, "size": size, "truth_samples": truth_samples,
           "alphas": list(alphas), "yaws": list(yaws),
           "configs": {k: c.as_dict() for k, c in configs.items()} | {
               "splitsum": split.as_dict()}}  # fmt: skip
    if shrm is not None:
        out["shrm"] = shrm
    check_map_names(paths)
    for path in paths:
        env = load_environment(str(path), quiet=True)
        if env.layout != "latlong":
            raise InputError(f"{path}: probe-eval takes lat-long maps (2:1)")
        plans = {k: fit_plan(c, env.shape) for k, c in configs.items()}
        if sheet_dir is not None:
            makedirs(sheet_dir)
        rows, _, nbytes, seconds = evaluate_map(env, plans, split, dfg, size, truth_samples,
                                                alphas, yaws, cache_dir=cache_dir,
                                                sheet_dir=sheet_dir, label=Path(path).stem,
                                                shrm=shrm)  # fmt: skip
        out["maps"][Path(path).stem] = rows
        out["bytes"] = nbytes
        out["seconds"][Path(path).stem] = seconds
        if progress:
            progress(Path(path).stem, rows)
    return out


def shrm_shortfalls(result: dict) -> list[str]:
    """One line per ``α`` whose SHRM could not reach ``1 − ε`` within the caps: the orders
    used and the energy fraction captured (no silent substitution)."""
    s = result.get("shrm")
    if not s:
        return []
    lines = []
    for row in s["orders"]:
        short = [t for t in ("E0", "E1") if not row[t]["reached"]]
        if short:
            used = ", ".join(f"{t} F {row[t]['F']} P {row[t]['P']} captures "
                             f"{row[t]['captured']:.3f}" for t in ("E0", "E1"))  # fmt: skip
            lines.append(
                f"SHRM at α {row['alpha']:.4g} (r {row['roughness']:.3g}): ε = "
                f"{s['eps']:g} is not reachable within F ≤ {s['F_limit']}, P ≤ "
                f"{s['P_limit']} ({'/'.join(short)}); used {used} of the BRDF energy"
            )
    return lines


def win_table(result: dict, method: str, baseline: str) -> dict:
    """Wins of ``method`` over ``baseline``: per (material, α) and per (map, material, α),
    and in total, as ``(wins, cases)`` pairs; ties (MSE difference below the truth's own
    error estimate) are counted apart. Cases where either probe has no MSE (``α`` outside
    its range, or not evaluated) are left out."""
    cell, by_map, total, ties = {}, {}, [0, 0], 0
    for name, rows in result["maps"].items():
        for r in rows:
            m, b = r["mse"].get(method), r["mse"].get(baseline)
            if m is None or b is None:
                continue
            win = m < b
            key = (r["material"], r["alpha"])
            for table, k in ((cell, key), (by_map, (name, *key))):
                w, n = table.get(k, (0, 0))
                table[k] = (w + win, n + 1)
            total = [total[0] + win, total[1] + 1]
            ties += abs(m - b) < r["mse_truth_estimate"]
    return {"cells": cell, "by_map": by_map, "total": tuple(total), "ties": ties}


COMPARISONS = (("shexp_v2", "splitsum_plain"), ("shexp_v2", "splitsum_filtered"),
               ("shexp_paper", "splitsum_plain"), ("shexp_paper", "splitsum_filtered"),
               ("shrm", "splitsum_plain"), ("shrm", "splitsum_filtered"),
               ("shrm", "shexp_v2"))  # fmt: skip
"""(method, baseline) pairs counted by :func:`win_table` in the report and the CLI."""

COLUMNS = (("shexp_v2", "SH-exp v2"), ("shexp_paper", "SH-exp paper"),
           ("splitsum_plain", "split-sum plain"), ("splitsum_filtered", "split-sum filtered"),
           ("shrm", "GGX SHRM"))  # fmt: skip


def present_comparisons(result: dict) -> list[tuple[str, str]]:
    """The :data:`COMPARISONS` with at least one case in ``result``."""
    return [c for c in COMPARISONS if win_table(result, *c)["total"][1] > 0]


def _mse(v) -> str:
    return "n/a" if v is None else f"{v:.3e}"


def check_map_names(paths) -> None:
    """A :class:`~shbake.errors.ParameterError` when two of ``paths`` share a file name
    without its suffix: results are kept per name (``result["maps"]``), so the second
    would replace the first."""
    stems = [Path(p).stem for p in paths]
    twice = sorted({s for s in stems if stems.count(s) > 1})
    if twice:
        names = ", ".join(map(repr, twice))
        raise ParameterError(f"maps named {names} are given more than once: results are kept "
                             "per file name (without its suffix)")  # fmt: skip


def mean_bake_seconds(result: dict) -> dict:
    """Each probe's bake seconds, the mean over the maps that baked it (``result["seconds"]``,
    :func:`evaluate_maps`); empty for a result without seconds."""
    out = {}
    for per_map in (result.get("seconds") or {}).values():
        for name, sec in per_map.items():
            out.setdefault(name, []).append(sec)
    return {name: sum(v) / len(v) for name, v in out.items()}


def markdown_report(result: dict) -> str:
    """Win rates per α and material for the :data:`COMPARISONS` present, bytes per probe
    and bake seconds (mean over the maps; a result without ``"seconds"``, as written before
    they were measured, has no such column), the SHRM's orders and captured energy, and the
    full per-map table and case list (``n/a``: the probe does not cover that ``α``)."""
    comps = present_comparisons(result)
    tables = {c: win_table(result, *c) for c in comps}
    keys = sorted({k for t in tables.values() for k in t["cells"]})
    head = " | ".join(f"{m} vs {b}" for m, b in comps)
    lines = [f"| material | α | {head} |", "|---|---|" + "---|" * len(comps)]
    for k in keys:
        cells = " | ".join("{}/{}".format(*tables[c]["cells"][k]) if k in tables[c]["cells"]
                           else "n/a" for c in comps)  # fmt: skip
        lines.append(f"| {k[0]} | {k[1]:.4g} | {cells} |")
    totals = []
    for c in comps:
        w, n = tables[c]["total"]
        totals.append(f"**{w}/{n} ({100 * w / n:.1f} %)**")
    lines.append(f"| all | all | {' | '.join(totals)} |")
    lines += [
        "",
        "ties (|ΔMSE| below the truth's own error estimate): "
        + ", ".join(f"{m} vs {b}: {tables[(m, b)]['ties']}" for m, b in comps),
    ]
    per_map = result.get("seconds")
    if per_map:
        means = mean_bake_seconds(result)
        lines += ["", f"| probe | bytes per probe | bake s (mean of {len(per_map)} "
                  f"map{'s' if len(per_map) != 1 else ''}) |", "|---|---|---|"]  # fmt: skip
        for k, v in result["bytes"].items():
            mean = f"{means[k]:.3g}" if k in means else "n/a"
            lines.append(f"| {k} | {v} | {mean} |")
    else:
        lines += ["", "| probe | bytes per probe |", "|---|---|"]
        lines += [f"| {k} | {v} |" for k, v in result["bytes"].items()]
    s = result.get("shrm")
    if s:
        lines += ["", f"GGX SHRM: ε = {s['eps']:g}, face {s['face_size']}² × 6, caps "
                  f"F ≤ {s['F_limit']}, P ≤ {s['P_limit']}; E0 (F0 = 1) and E1 (F0 = 0) per α:",
                  "", "| α | r | E0 F, P | E0 energy captured | E1 F, P | E1 energy captured "
                  "| 1 − ε reached |", "|---|---|---|---|---|---|---|"]  # fmt: skip
        for row in s["orders"]:
            e0, e1 = row["E0"], row["E1"]
            lines.append(
                f"| {row['alpha']:.4g} | {row['roughness']:.3g} | {e0['F']}, {e0['P']} "
                f"| {e0['captured']:.4f} | {e1['F']}, {e1['P']} | {e1['captured']:.4f} "
                f"| {'yes' if e0['reached'] and e1['reached'] else 'no (capped)'} |"
            )
    lines += [
        "",
        "Per map (wins: " + " / ".join(f"{m} vs {b}" for m, b in comps) + ", out of 4 views):",
        "",
        "| map | material | α | wins |",
        "|---|---|---|---|",
    ]
    for k in sorted({k for t in tables.values() for k in t["by_map"]}):
        cells = " / ".join(str(tables[c]["by_map"][k][0]) if k in tables[c]["by_map"] else "–"
                           for c in comps)  # fmt: skip
        lines.append(f"| {k[0]} | {k[1]} | {k[2]:.4g} | {cells} |")
    cols = [
        (k, label)
        for k, label in COLUMNS
        if any(k in r["mse"] for rows in result["maps"].values() for r in rows)
    ]
    lines += [
        "",
        "Cases (MSE):",
        "",
        "| map | material | α | yaw | "
        + " | ".join(lb for _, lb in cols)
        + " | truth error (est.) |",
        "|---|---|---|---|" + "---|" * (len(cols) + 1),
    ]
    for name, rows in result["maps"].items():
        for r in rows:
            m = r["mse"]
            cells = " | ".join(_mse(m.get(k)) for k, _ in cols)
            lines.append(
                f"| {name} | {r['material']} | {r['alpha']:.4g} | {r['yaw']:.0f} | "
                f"{cells} | {r['mse_truth_estimate']:.1e} |"
            )
    return "\n".join(lines) + "\n"


@path_arguments("source", "output")
def bake_splitsum_file(source, output, config: SplitSumConfig, negative="clamp",
                       fix_nonfinite=None) -> dict:  # fmt: skip
    """``split-sum``: read a lat-long map, prefilter its chain at ``config`` (checked when it
    was made), write the asset; a summary."""
    from shbake.batch.probe_jobs import shared_dfg_table
    from shbake.envmap import load_environment
    from shbake.errors import InputError
    from shbake.format.asset import write_asset
    from shbake.format.atomic import check_output_path

    check_output_path(output)
    env = load_environment(source, negative=negative, fix_nonfinite=fix_nonfinite, quiet=True)
    if env.layout != "latlong":
        raise InputError(f"{source}: split-sum takes lat-long maps (2:1), got {env.layout}")
    asset = build_splitsum_asset(prefilter_chain(env.pixels, config), config, shared_dfg_table(),
                                 env.meta)  # fmt: skip
    write_asset(output, asset)
    return {"output": output, "levels": config.levels, "bytes": probe_bytes(asset),
            "config": config.as_dict()}  # fmt: skip
