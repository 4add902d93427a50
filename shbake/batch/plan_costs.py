"""Predicted bake cost of a planned asset: the CPU seconds of its ``make`` recipe.

What a prediction means
    CPU seconds (user + system, all threads) of one ``shbake bake SCENE --asset
    ID`` process — the recipe of the emitted Makefile fragment — with numba's
    on-disk cache and shbake's plan cache warm (the plan warms both). With
    ``NUMBA_NUM_THREADS=1`` on an idle core this is the recipe's wall time; on a
    loaded machine wall time grows with the load while CPU time barely does, so
    CPU time is what is predicted and what ``bench/scene_acceptance.py``
    measures (``getrusage(RUSAGE_CHILDREN)`` around each recipe). Workers of
    ``bake --jobs`` and Dask pay the fixed part once per worker and kind, not
    once per asset, so their totals are lower.

The model
    ``predicted = overhead[recipe class] + load(map) + work(settings)``

    * ``overhead``: everything a recipe pays whatever its input — interpreter
      start, imports, reading the scene file, numba cache loads, EXR decode and
      HDF5 write of a tiny asset. Measured once per machine and code version by
      :func:`recipe_overheads`: a scene with a 16 × 32 map and the smallest
      settings of each class is baked in fresh processes, each recipe twice (the
      first fills the caches), the CPU time of the second is kept.
    * ``load``: CPU time of :func:`shbake.envmap.load_environment` on the map
      (EXR decode, layout), measured at plan time.
    * ``work``: the baker's own work at the chosen settings, CPU time measured
      at plan time on the real input or at a reduced size and scaled
      (:mod:`shbake.batch.plan` says how per kind).

Recipe classes: ``env_sh``, ``brdf_table``, ``shexp``, ``splitsum``, ``shrm``
and ``export:TARGET``. Measured overheads are cached in the plan cache folder
(:func:`shbake.batch.plan_cache.cache_dir`) as ``costs-<key>.json``, the key a
SHA-256 of the shbake version, the interpreter and the source of ``shbake`` and
``shbake_cli``; with the cache off they are measured on every plan.
"""

import hashlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import shbake

TINY_SHAPE = (16, 32)
"""Rows and columns of the calibration map."""
COSTS_FORMAT = 1


def cpu_timed(fn, *a, **k):
    """``(fn(*a, **k), CPU seconds of this process during the call)`` (all threads)."""
    t0 = time.process_time()
    out = fn(*a, **k)
    return out, time.process_time() - t0


WARMED: set[str] = set()
"""Kinds already called once in this process (numba cache loads, lazy imports done)."""


def warm_seconds(kind: str, fn, *a, **k) -> float:
    """Warm CPU seconds of ``fn(*a, **k)``: the first call per kind and process is not timed
    (its numba cache loads and imports are the recipe's fixed part,
    :func:`shbake.batch.plan_costs.recipe_overheads`); short calls: the best of three."""
    if kind not in WARMED:
        fn(*a, **k)
        WARMED.add(kind)
    best = cpu_timed(fn, *a, **k)[1]
    for _ in range(2 if best < 0.05 else 0):  # short calls: the best of three (timer noise)
        best = min(best, cpu_timed(fn, *a, **k)[1])
    return best


_SHAPE_SECONDS: dict = {}


def shape_seconds(kind: str, key, fn, *a, **k) -> float:
    """:func:`warm_seconds` of ``fn(*a, **k)``, measured once per process for each ``(kind,
    key)``: work whose cost depends only on the map's shape and the settings (``key``), not
    on its pixels — a projection, a fit with its plan, a prefiltered chain — is timed on the
    first map of that shape and reused for the others (the plan of N maps then times it
    once, not N times)."""
    if (kind, key) not in _SHAPE_SECONDS:
        _SHAPE_SECONDS[kind, key] = warm_seconds(kind, fn, *a, **k)
    return _SHAPE_SECONDS[kind, key]


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def recipe_command(scene: str, aid: str) -> list[str]:
    """The recipe of asset ``aid`` as this interpreter runs it (what ``$(SHBAKE) bake`` does)."""
    return [sys.executable, "-m", "shbake_cli.main", "bake", scene, "--asset", aid, "--quiet"]


def run_recipe(scene: str, aid: str, env: dict | None = None) -> tuple[float, float]:
    """Run one recipe in a fresh process; ``(CPU seconds, wall seconds)`` it took."""
    c0, t0 = _children_cpu(), time.perf_counter()
    done = subprocess.run(recipe_command(scene, aid), env=env, capture_output=True, text=True)
    if done.returncode != 0:
        from shbake.errors import OutputError

        tail = (done.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise OutputError(f"cost calibration: recipe {aid} failed: {tail}")
    return _children_cpu() - c0, time.perf_counter() - t0


def _code_key() -> str:
    h = hashlib.sha256()
    h.update(f"{COSTS_FORMAT} {shbake.__version__} {sys.executable}".encode())
    import importlib.util

    cli = importlib.util.find_spec("shbake_cli")  # the recipe's command code (not imported)
    roots = [Path(shbake.__file__).parent] + ([Path(cli.origin).parent] if cli else [])
    for root in roots:
        for p in sorted(root.rglob("*.py")):
            h.update(p.relative_to(root).as_posix().encode())
            h.update(p.read_bytes())
    return h.hexdigest()[:24]


def _tiny_assets(out: str, tiny_map: str) -> dict:
    """The calibration scene's assets (as their settings stamps hold them), by recipe class."""
    from shbake.bakers.shexp import FitConfig
    from shbake.bakers.splitsum import SplitSumConfig

    def asset(aid, kind, settings, inputs=(tiny_map,)):
        return {"id": aid, "kind": kind, "output": os.path.join(out, aid + ".h5"),
                "inputs": list(inputs), "input_hashes": {}, "settings": settings}  # fmt: skip

    env_sh = asset("env_sh/tiny", "env_sh", {"lmax": 2, "irradiance": True, "tangent": True,
                                             "extract_sun": True})  # fmt: skip
    out_assets = {
        "env_sh": env_sh,
        "brdf_table": asset("brdf_table/tiny", "brdf_table", {
            "model": "ashikhmin-shirley", "params": {"nu": 4, "nv": 1}, "merl": None,
            "lmax": 2, "size": 8, "samples": 256}, inputs=()),  # fmt: skip
        "shexp": asset("shexp/tiny", "shexp", {"fit": FitConfig.paper(
            alpha_min=0.25, alpha_max=0.81, alpha_count=4, samples=256).as_dict()}),  # fmt: skip
        "splitsum": asset("splitsum/tiny", "splitsum", {"splitsum": SplitSumConfig(
            top=16, min_size=8, alphas=(0.01, 0.5), samples=64).as_dict()}),  # fmt: skip
        "shrm": asset("shrm/tiny/m", "shrm", {
            "brdf": "phong", "params": {"n": 8}, "merl": None, "eps": 0.5, "F": 2, "P": 1,
            "face_size": 8}),  # fmt: skip
    }
    from shbake.batch.scene import EXPORTS

    for target in EXPORTS:
        a = asset(f"export/{target}/tiny", "export", {"target": target, "env_sh": "env_sh/tiny"},
                  inputs=(tiny_map, env_sh["output"]))  # fmt: skip
        a["output"] = os.path.join(out, "export", target, "tiny", "files.json")
        out_assets[f"export:{target}"] = a
    return out_assets


def measure_overheads(classes) -> dict[str, float]:
    """Bake the tiny calibration scene's recipes of ``classes`` (each twice); CPU seconds of
    the second run of each (module docstring)."""
    from shbake.batch.scene import settings_text, stamp_path

    classes = sorted(set(classes))
    result = {}
    with tempfile.TemporaryDirectory(prefix="shbake-costs-") as tmp:
        from shbake.format.atomic import detached
        from shbake.format.images import write_exr

        tiny_map = os.path.join(tmp, "tiny.exr")
        h, w = TINY_SHAPE
        px = np.full((h, w, 3), 0.5, np.float32)
        px[h // 4, w // 3] = 1e3  # a sun: the extraction path runs
        with detached():  # the recipes read it now, not when the command's outputs commit
            write_exr(tiny_map, px, half=False)
        scene = os.path.join(tmp, "tiny.toml")
        with open(scene, "w") as f:
            f.write('[scene]\nout_dir = "out"\n[[environments]]\nmap = "tiny.exr"\n'
                    '[[materials]]\nname = "m"\nkind = "diffuse"\n')  # fmt: skip
        out = os.path.join(tmp, "out")
        assets = _tiny_assets(out, tiny_map)
        order = (["env_sh"] if any(c.startswith("export:") for c in classes) else []) + classes
        for cls in dict.fromkeys(order):
            a = assets[cls]
            stamp = stamp_path(out, a["id"])
            os.makedirs(os.path.dirname(stamp), exist_ok=True)
            with open(stamp, "w") as f:
                f.write(settings_text(a))
            run_recipe(scene, a["id"])  # fills numba's and the plan cache
            result[cls] = run_recipe(scene, a["id"])[0]
    return {c: result[c] for c in classes}


def recipe_overheads(classes) -> dict[str, float]:
    """Fixed CPU seconds of each recipe class, from the per-machine cache or measured."""
    from shbake.batch.plan_cache import cache_dir
    from shbake.format.atomic import atomic_path

    classes = set(classes)
    folder = cache_dir()
    path = folder / f"costs-{_code_key()}.json" if folder is not None else None
    known: dict = {}
    if path is not None:
        try:
            known = json.loads(path.read_text())
        except (OSError, ValueError):
            known = {}
    missing = classes - set(known)
    if missing:
        known.update(measure_overheads(missing))
        if path is not None:
            os.makedirs(folder, exist_ok=True)
            with atomic_path(str(path), independent=True) as tmp, open(tmp, "w") as f:
                json.dump(known, f, indent=1, sort_keys=True)
    return {c: float(known[c]) for c in classes}
