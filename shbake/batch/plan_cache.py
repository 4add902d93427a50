"""On-disk cache of quadrature plans and the DFG table, shared by worker processes and runs.

A :class:`~shbake.bakers.shexp_targets.QuadraturePlan` depends only on the fit
configuration and the map shape, yet takes seconds to build (16 384 targets ×
1024 samples by default) while a probe takes tens of milliseconds. A build
pipeline that calls ``shbake probe-fit`` once per probe (``make -j``) would
rebuild it every time; the cache builds it once per machine. The DFG table
(:func:`~shbake.bakers.dfg.dfg_table`, about a second) is cached
the same way.

Location: ``$SHBAKE_CACHE_DIR``, else ``$XDG_CACHE_HOME/shbake``, else
``~/.cache/shbake``; ``SHBAKE_CACHE_DIR=off`` disables it. Entries are named
by a SHA-256 of the configuration, the shape, the plan format, the shbake
version and the source of the modules that build plans, written
atomically, and rebuilt when unreadable. A cached plan is
the same bytes a fresh build gives, so outputs do not depend on the cache.
"""

import functools
import hashlib
import json
import os
import zipfile
from pathlib import Path

import numpy as np

import shbake
from shbake.bakers import dfg, shexp_targets
from shbake.bakers.shexp import FitConfig, FitPlan
from shbake.bakers.shexp_targets import QuadraturePlan
from shbake.brdf import ggx, sampling
from shbake.conventions import DFG_SIZE
from shbake.envmap import importance, layouts
from shbake.format.atomic import atomic_path
from shbake.reference import ggx as reference_ggx

CACHE_ENV = "SHBAKE_CACHE_DIR"
ARRAYS = ("offsets", "index", "weight", "views", "normals", "alphas")
PLAN_FORMAT = 2


def cache_dir() -> Path | None:
    """The plan cache folder, or ``None`` when disabled."""
    setting = os.environ.get(CACHE_ENV)
    if setting is not None:
        return None if setting.strip().lower() in ("", "off") else Path(setting)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "shbake"


def plan_key(config: FitConfig, shape: tuple[int, int]) -> str:
    spec = {
        "config": config.as_dict(),
        "shape": list(shape),
        "format": PLAN_FORMAT,
        "version": shbake.__version__,
        "code": _code_digest(),
    }
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:32]


@functools.lru_cache(maxsize=1)
def _code_digest() -> str:
    """SHA-256 of the modules that build a plan: any change to them is a new key."""
    digest = hashlib.sha256()
    for module in (shexp_targets, importance, layouts, ggx, sampling, dfg, reference_ggx):
        digest.update(Path(module.__file__).read_bytes())
    return digest.hexdigest()


def _load(path: Path) -> QuadraturePlan | None:
    try:
        with np.load(path) as z:
            shape = tuple(int(x) for x in z["shape"])
            return QuadraturePlan(shape, int(z["levels"]), *(z[k] for k in ARRAYS))
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
        return None  # a truncated or foreign entry is rebuilt


def _store(path: Path, write) -> None:
    """Write a cache entry atomically with ``write(file)``."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(str(path), independent=True) as tmp, open(tmp, "wb") as f:
            write(f)
    except OSError:
        pass  # a cache that cannot be written only costs time


def _save(path: Path, plan: QuadraturePlan) -> None:
    arrays = {k: getattr(plan, k) for k in ARRAYS}
    _store(path, lambda f: np.savez(f, shape=np.array(plan.shape), levels=np.array(plan.levels),
                                    **arrays))  # fmt: skip


def cached_fit_plan(config: FitConfig, shape: tuple[int, int]) -> FitPlan:
    """The :class:`FitPlan` of ``config`` and ``shape``, its quadrature from the cache."""
    folder = cache_dir()
    if folder is None or config.targets != "quadrature":
        return FitPlan(config, shape)
    path = folder / f"plan-{plan_key(config, shape)}.npz"
    quadrature = _load(path) if path.exists() else None
    plan = FitPlan(config, shape, quadrature)
    if quadrature is None:
        _save(path, plan.targets)
    return plan


def cached_dfg_table() -> np.ndarray:
    """The shared DFG table (:func:`shbake.bakers.dfg.dfg_table`), from the cache."""
    folder = cache_dir()
    if folder is None:
        return dfg.dfg_table()
    path = folder / f"dfg-{_code_digest()[:32]}.npy"
    try:
        table = np.load(path)
        if table.shape == (DFG_SIZE, DFG_SIZE, 2):
            return table
    except (OSError, ValueError, EOFError):
        pass
    table = dfg.dfg_table()
    _store(path, lambda f: np.save(f, table))
    return table


SCENE_UNITS_FORMAT = 1


def _scene_units_path(scene_path: str) -> Path | None:
    folder = cache_dir()
    if folder is None:
        return None
    spec = f"{SCENE_UNITS_FORMAT} {shbake.__version__} {os.path.abspath(scene_path)}"
    return folder / f"units-{hashlib.sha256(spec.encode()).hexdigest()[:32]}.json"


def scene_units(scene_path: str) -> dict:
    """The per-unit plans ``shbake plan`` last measured for the scene at ``scene_path``
    (:func:`store_scene_units`), so that a ``bake`` from a cold output folder does not plan
    again; ``{}`` when there are none or the entry is not one (read as untrusted: only
    objects keyed by strings are kept). Each unit's key names its inputs' bytes and settings
    (:func:`shbake.batch.plan.plan_scene`), so an entry of an older scene is never used for
    changed inputs."""
    path = _scene_units_path(scene_path)
    if path is None:
        return {}
    try:
        with open(path, encoding="utf-8") as f:
            units = json.loads(f.read(64 << 20))
    except (OSError, ValueError, RecursionError):
        return {}
    if not isinstance(units, dict):
        return {}
    return {k: v for k, v in units.items() if isinstance(k, str) and isinstance(v, dict)}


def store_scene_units(scene_path: str, units: dict) -> None:
    """Keep ``units`` (unit key → plan) for the scene at ``scene_path`` in the plan cache
    (atomically; a cache that cannot be written only costs a re-plan)."""
    path = _scene_units_path(scene_path)
    if path is not None:
        data = json.dumps(units, sort_keys=True).encode()
        _store(path, lambda f: f.write(data))
