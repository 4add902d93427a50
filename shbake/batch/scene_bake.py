"""Baking a planned scene: one function per asset, the same for make, a local pool and Dask.

:func:`bake_asset` takes an asset of the plan (:mod:`shbake.batch.plan`),
writes its file atomically (:func:`shbake.format.asset.write_asset`) and
returns a record with the output's hash, the measured error and the time.
Nothing in an asset depends on where or when it was baked (no times, no
command lines), so ``make -j``, ``bake --jobs`` and ``bake --scheduler``
write identical bytes. :func:`bake_scene` plans, skips every asset whose
plan key, inputs and output hash match ``scene.lock.json``, bakes the rest
and rewrites the lock (atomically).
"""

import functools
import hashlib
import json
import os
import re
import shlex
import stat
import time
from contextlib import contextmanager

from shbake import __version__, resources
from shbake.batch.makefile import (
    MakeNameError,
    line_start_path,
    make_path,
    shell_word,
    variable_name,
    variable_value,
)
from shbake.batch.plan import file_hash, plan_scene_kept
from shbake.batch.scene import (
    NAME_PATTERN,
    STAMP_DIR,
    Scene,
    asset_output,
    is_inside,
    lock_path,
    param_strings,
    settings_text,
    settings_value,
    stamp_path,
    written_by_shbake,
)
from shbake.batch.scene_paths import resolved, scene_folder, stored, stored_asset
from shbake.batch.scheduler import CONNECT_SECONDS
from shbake.batch.workers import start_server, worker_pool
from shbake.errors import OutputError, ParameterError
from shbake.format.atomic import (
    atomic_path,
    check_output_path,
    collected,
    detached,
    listed_once,
    makedirs,
    staged,
    transaction,
    write_text,
)
from shbake.jit import use_one_thread
from shbake.resources import path_arguments

ASSET_ID = rf"[a-z_]+(?:/{NAME_PATTERN})+"
"""An asset id: its kind, then the names it is baked for (``shrm/satin/dusk``)."""


@contextmanager
def _committed():
    """Each asset's files commit on their own when its baker returns (outside the command's
    transaction), so the bake can hash and measure them, and completed assets stay when a
    later one fails."""
    with detached(), transaction():
        yield


def _bake_env_sh(a: dict, measure: bool = True) -> tuple[dict, dict]:
    """An env_sh asset, its projection ``a["planned_projection"]`` (:func:`_with_planned`)
    when that is one of these settings; measured: its irradiance against the pyramid brute
    force (:func:`shbake.evaluation.env_sh.check_reference`) of the map the bake decoded
    (its pixels as the asset's recorded policies read them, unturned), the asset as written
    taken from memory (its values are the file's: every dataset is stored in its own
    dtype)."""
    from shbake.bakers.env_sh import Projection
    from shbake.batch.project_env import project_environment_asset
    from shbake.envmap.sun import SUN_RADIUS_DEG
    from shbake.envmap.turn import turn_matrix
    from shbake.evaluation.env_sh import check_reference, irradiance_errors

    s = a["settings"]
    projection = Projection.from_record(a.get("planned_projection"), s["lmax"],
                                        SUN_RADIUS_DEG if s["extract_sun"] else None)  # fmt: skip
    t0 = time.perf_counter()
    with _committed():
        asset, summary, env = project_environment_asset(
            a["inputs"][0], a["output"], lmax=s["lmax"], irradiance_lmax=s["lmax"],
            irradiance_sh=s["irradiance"], tangent_irradiance=s["tangent"],
            extract_sun=s["extract_sun"], lights=s.get("lights"), quiet=True,
            pose=s.get("pose"), projection=projection,
        )  # fmt: skip
    seconds = time.perf_counter() - t0
    outputs = summary["outputs"]
    if not measure:
        return {"outputs": outputs, "bake_seconds": seconds}, {}
    names = [n for n, on in (("irradiance", s["irradiance"]), ("tangent_irradiance", s["tangent"]))
             if on]  # fmt: skip
    ref = check_reference(env, names)
    turn = turn_matrix(s.get("pose", {}).get("rotation_deg", 0.0))
    measured = irradiance_errors(asset, env, ref, rotation=turn)  # the scene's tolerances
    errors = {name: e["relative_rms"] for name, e in measured.items()}
    return {"outputs": outputs, "bake_seconds": seconds, "error_method": ref["methods"]}, errors


def _bake_brdf_table(a: dict, measure: bool = True) -> tuple[dict, dict]:
    from shbake.batch.brdf_table import bake_brdf_table

    s = a["settings"]
    t0 = time.perf_counter()
    with _committed():
        summary = bake_brdf_table(s["model"], a["output"], params=param_strings(s["params"]),
                                  merl_path=s["merl"], lmax=s["lmax"], size=(s["size"], s["size"]),
                                  samples=s["samples"], reproducible=True)  # fmt: skip
    seconds = time.perf_counter() - t0
    info = {"outputs": [a["output"]], "bake_seconds": seconds}
    if not measure:
        return info, {}
    # the bake's headline: table_error on views the plan did not use, against the table it
    # wrote (a scene's table varies no axis, so the headline's BRDF is the scene's)
    info["error_method"] = {"brdf_table": "reference-projection"}
    return info, {"brdf_table": summary["error"]}


def _posed_env(a: dict, turn_pixels: bool):
    """The asset's map, its probe pose recorded (and its pixels turned with ``turn_pixels``);
    ``(environment, SH turn or None)``."""
    from shbake.envmap import load_environment
    from shbake.envmap.turn import apply_pose

    env = load_environment(a["inputs"][0], quiet=True)
    pose = a["settings"].get("pose")
    rotation = apply_pose(env, pose, turn_pixels) if pose is not None else None
    return env, rotation


def _bake_shexp(a: dict, measure: bool = True) -> tuple[dict, dict]:
    """An SH-exp probe; ``a["planned_fit"]`` (:func:`_with_planned`): the plan's fit of
    the same map at the same settings, written as it is when it is one (else fitted here);
    measured: the fit's RMS log residual."""
    from shbake.bakers.shexp import FitConfig, ShexpProbe
    from shbake.batch.probe_jobs import fit_plan, shared_dfg_table
    from shbake.format.asset import write_asset
    from shbake.format.shexp import build_shexp_asset

    t0 = time.perf_counter()
    env, _ = _posed_env(a, turn_pixels=True)
    if env.layout != "latlong":
        raise ParameterError(f"{a['inputs'][0]}: SH-exp probes take lat-long maps (2:1)")
    config = FitConfig(**a["settings"]["fit"])
    probe = ShexpProbe.from_record(a.get("planned_fit"), config)  # the plan's fit, same bits
    if probe is None:
        probe = fit_plan(config, env.shape).fit_many([env.pixels])[0]
    with _committed():
        write_asset(a["output"], build_shexp_asset(probe, config, shared_dfg_table(), env.meta))
    return ({"outputs": [a["output"]], "bake_seconds": time.perf_counter() - t0,
             "error_method": {"glossy_probe": "fit-residual"}},
            {"glossy_probe": float(probe.stats["log_rms"])})  # fmt: skip


def _bake_splitsum(a: dict, measure: bool = True) -> tuple[dict, dict]:
    from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
    from shbake.batch.probe_jobs import shared_dfg_table
    from shbake.format.asset import write_asset
    from shbake.format.splitsum import build_splitsum_asset

    t0 = time.perf_counter()
    c = a["settings"]["splitsum"]
    config = SplitSumConfig(**(c | {"alphas": tuple(c["alphas"])}))
    env, _ = _posed_env(a, turn_pixels=True)
    chain = prefilter_chain(env.pixels, config)
    with _committed():
        write_asset(a["output"], build_splitsum_asset(chain, config, shared_dfg_table(),
                                                      env.meta))  # fmt: skip
    return {"outputs": [a["output"]], "bake_seconds": time.perf_counter() - t0}, {}


def _bake_shrm(a: dict, measure: bool = True) -> tuple[dict, dict]:
    """An SHRM at the planned ``F``, ``P`` and face size; measured: the relative energy of
    the shading error on a sphere against brute force under the (turned) map
    (:class:`shbake.evaluation.shrm.ShrmCheck`), comparable with the BRDF energy left out."""
    from shbake.bakers.shrm import bake_shrm
    from shbake.brdf.reflection import make_reflection_brdf
    from shbake.evaluation.shrm import ShrmCheck
    from shbake.format.shrm import build_shrm_asset, write_shrm

    s = a["settings"]
    t0 = time.perf_counter()
    env, rotation = _posed_env(a, turn_pixels=False)
    rb = make_reflection_brdf(s["brdf"], param_strings(s["params"]), s["merl"])
    bake = bake_shrm(env, rb, s["eps"], s["F"], s["P"], s["face_size"], rotation=rotation)
    asset = build_shrm_asset(bake, env.meta)
    with _committed():
        write_shrm(a["output"], asset)
    info = {"outputs": [a["output"]], "bake_seconds": time.perf_counter() - t0}
    if not measure:
        return info, {}
    check = ShrmCheck(env, rb, rotation=rotation)
    if check.ref is None:
        return info, {}
    return info | {"error_method": {"shrm": "brute-force"}}, {"shrm": check.rel_energy(asset)}


def _bake_export(a: dict, measure: bool = True) -> tuple[dict, dict]:
    from shbake.batch.export import export_assets, export_error

    t0 = time.perf_counter()
    folder = os.path.dirname(a["output"])
    env_map, env_sh = a["inputs"]
    with _committed():
        files = export_assets([env_sh], a["settings"]["target"], folder, env_path=env_map,
                              many=True)  # fmt: skip
    listing = {os.path.relpath(f, folder): file_hash(staged(f) or f, own_output=True)
               for f in sorted(files)}  # fmt: skip
    with _committed():
        write_text(a["output"], json.dumps(listing, indent=1, sort_keys=True) + "\n")
    info = {"outputs": [a["output"]] + sorted(files), "bake_seconds": time.perf_counter() - t0}
    if not measure or a["settings"]["target"] == "ktx2":  # ktx2: cube maps, no SH
        return info, {}
    errors, methods = export_error(env_sh, env_map, scene_check=True)
    return info | {"error_method": methods}, {"irradiance": errors["relative_rms"]}


BAKERS = {"export": _bake_export, "env_sh": _bake_env_sh, "brdf_table": _bake_brdf_table,
          "shexp": _bake_shexp, "shrm": _bake_shrm,
          "splitsum": _bake_splitsum}  # fmt: skip

COPIED_KINDS = ("env_sh", "shexp", "splitsum", "shrm")
"""Kinds whose asset is one file made from one map and its settings alone: probes whose maps
have the same bytes and whose settings are the same but for their position are baked once
(:func:`same_work`)."""


def _work_key(a: dict) -> str:
    """What an asset of :data:`COPIED_KINDS` is made from: its kind, its plan key (the map's
    bytes and the tolerances) and its settings, the probe's position left out (recorded
    only: no baker uses it)."""
    settings = dict(a["settings"])
    if "pose" in settings:
        settings["pose"] = {k: v for k, v in settings["pose"].items() if k != "position"}
    return json.dumps([a["kind"], a["plan_key"], a["input_hashes"], settings], sort_keys=True)


def same_work(wave: list[dict]) -> tuple[list[dict], dict[str, list[dict]]]:
    """``wave`` split into the assets to bake and, by the id of each asset baked, the assets
    that are the same work (:func:`_work_key`: maps with the same bytes — copies, links —
    and the same settings), written from its bake (:func:`_copy_baked`)."""
    first: dict[str, dict] = {}
    bake, copies = [], {}
    for a in wave:
        f = first.setdefault(_work_key(a), a) if a["kind"] in COPIED_KINDS else a
        if f is a:
            bake.append(a)
        else:
            copies.setdefault(f["id"], []).append(a)
    return bake, copies


def _copy_baked(a: dict, measure: bool = True) -> tuple[dict, dict]:
    """Asset ``a`` written from the bake of the same work (:func:`same_work`;
    ``a["copy_of"]``: that asset's output and lock record), read back as written, its
    provenance saying ``a``'s own map and position as ``a``'s own bake would (the same
    bytes, ``tests/batch/test_scene_scale.py``); its measured error is that bake's."""
    import numpy as np

    from shbake.format.asset import Asset, write_asset

    t0 = time.perf_counter()
    first = a["copy_of"]
    path = staged(first["output"]) or first["output"]  # what this run staged, or its file
    baked = _baked_asset(file_hash(path, own_output=True), path)
    attrs = dict(baked.attrs, source_path=os.path.abspath(a["inputs"][0]))
    if "pose" in a["settings"]:  # as shbake.envmap.turn.apply_pose records it
        attrs["probe_position"] = np.asarray(a["settings"]["pose"]["position"], np.float64)
    with _committed():
        write_asset(a["output"], Asset(baked.kind, attrs, baked.datasets, baked.dataset_attrs))
    info = {"outputs": [a["output"]], "bake_seconds": time.perf_counter() - t0,
            "error_method": first["error_method"]}  # fmt: skip
    return info, first["measured_error"]


@functools.lru_cache(maxsize=16)
def _baked_asset(digest: str, path: str):
    """The asset in the file ``path`` whose SHA-256 is ``digest``, read once for all its
    copies in a task (:func:`_copy_baked`; ~20 ms a read, about what writing a copy costs);
    the caller must not change it."""
    from shbake.format.asset import read_asset

    return read_asset(path)


_WARM: set[str] = set()


def bake_asset(asset: dict, measure: bool = True) -> dict:
    """Bake one planned asset; its lock record (outputs' hashes, measured error, seconds).

    ``measure``: also measure its error against the references (what the lock records).
    An asset with ``copy_of`` (:func:`same_work`) is written from that bake, its record
    naming it (``copy_of``: its id). The folders it creates for its output are removed
    again if it fails.
    """
    baker = _copy_baked if "copy_of" in asset else BAKERS[asset["kind"]]
    with detached(), transaction() as folders:
        folders.makedirs(os.path.dirname(asset["output"]))
        if measure and baker is not _copy_baked and asset["kind"] not in _WARM:
            # the first asset of a kind in this process is baked (and checked) once into a
            # scratch folder so that the times recorded are warm (numba cache loads, the
            # check's pyramid geometry excluded), as the plan predicts
            import tempfile

            with tempfile.TemporaryDirectory() as tmp:
                scratch = dict(asset, output=os.path.join(tmp, "warm.h5"))
                BAKERS[asset["kind"]](scratch, measure)  # its check's first call too
            _WARM.add(asset["kind"])
        t0 = time.perf_counter()
        info, errors = baker(asset, measure)
        wall = time.perf_counter() - t0
    folder = os.path.dirname(asset["output"])  # read back from a collector's scratch (Dask)
    outputs = {os.path.relpath(p, folder): file_hash(staged(p) or p, own_output=True)
               for p in info["outputs"]}  # fmt: skip
    return {
        "id": asset["id"],
        "plan_key": asset["plan_key"],
        "settings": asset["settings"],
        "inputs": {p: file_hash(staged(p) or p) for p in asset["inputs"]},
        "outputs": outputs,
        "measured_error": errors,
        "error_method": info.get("error_method", {}) if measure else {},
        "tolerances": asset["tolerances"],
        "predicted_error": asset["predicted_error"],
        "predicted_seconds": asset["predicted_seconds"],
        "bake_seconds": info["bake_seconds"],
        "seconds_with_check": wall,
    } | ({"copy_of": asset["copy_of"]["id"]} if "copy_of" in asset else {})


CHUNK_MAPS = 8
"""Maps whose assets one task bakes (a pool's or a Dask worker's unit of work): enough to
amortise the task's scheduling and share each map's decode between its assets and checks,
few enough to balance two workers from a few dozen maps on."""


def chunks(wave: list[dict], maps: int = CHUNK_MAPS) -> list[list[dict]]:
    """``wave``'s assets in tasks of the assets of ``maps`` maps each (an asset without a map,
    a BRDF table, a task of its own group), in the wave's order within a task."""
    groups: dict = {}
    for a in wave:
        key = a["inputs"][0] if a["kind"] != "brdf_table" and a["inputs"] else ("", a["id"])
        groups.setdefault(key, []).append(a)
    ordered = list(groups.values())
    return [[a for g in ordered[i : i + maps] for a in g] for i in range(0, len(ordered), maps)]


def bake_chunk(assets: list[dict]) -> list[dict]:
    """Bake ``assets`` (:func:`bake_asset`, in order), each map decoded once for all of them
    and their checks (:func:`shbake.envmap.environment.decoded_once`), each output folder
    listed once for stale temporaries (:func:`shbake.format.atomic.listed_once`); their
    records."""
    from shbake.envmap.environment import decoded_once

    with decoded_once(), listed_once():
        return [bake_asset(a) for a in assets]


def _dask_bake(assets: list[dict], sources: dict[str, bytes]) -> list[tuple[dict, dict]]:
    """A Dask worker's bake of a chunk of ``assets``: per asset, its lock record and its
    outputs' bytes by path relative to the asset's folder, for the client to write (the
    worker writes nothing where outputs go, :mod:`shbake.batch.scheduler`). ``sources``: the
    bytes of inputs that this run baked earlier (the env_sh assets of exports), not yet
    committed."""
    use_one_thread()
    with collected() as outputs:
        for path, data in sources.items():
            outputs.adopt(path, data)
        out = []
        for asset, record in zip(assets, bake_chunk(assets), strict=True):
            folder = os.path.dirname(asset["output"])
            out.append((record, {rel: outputs.read(os.path.join(folder, rel))
                                 for rel in record["outputs"]}))  # fmt: skip
        return out


def _bake_on_scheduler(client, wave: list[dict]) -> list[dict]:
    """Bake ``wave`` on Dask; each output is written here, in this run's transaction, as its
    task completes (the whole run is then committed together with the lock, or not at
    all); records in the wave's order."""
    from shbake.batch.scheduler import completed, inside, write_returned

    for a in wave:  # the workers check them (removed again if the run fails)
        makedirs(os.path.dirname(a["output"]))
    tasks = chunks(wave)
    sources = [{p: _staged_bytes(p) for a in task for p in _read_outputs(a) if staged(p)}
               for task in tasks]  # fmt: skip
    records: list = [None] * len(tasks)
    futures = client.map(_dask_bake, tasks, sources, pure=False)
    for i, baked in completed(client, futures):  # written as each task returns
        for asset, (record, files) in zip(tasks[i], baked, strict=True):
            folder = os.path.dirname(asset["output"])
            for rel, data in files.items():
                if hashlib.sha256(data).hexdigest() != record["outputs"].get(rel):
                    raise OutputError(f"{asset['id']}: {rel} differs from its lock record")
                write_returned(inside(folder, rel), data)
        records[i] = [record for record, _ in baked]
    return [r for task in records for r in task]


def _read_outputs(asset: dict) -> list[str]:
    """The files ``asset``'s bake reads that the run may have written: its inputs (an
    export's ``env_sh`` asset) and the asset it is a copy of."""
    return asset["inputs"] + ([asset["copy_of"]["output"]] if "copy_of" in asset else [])


COPIED_RECORD = ("id", "measured_error", "error_method")
"""What a copy's record takes from the record of the bake it copies (:func:`_copy_baked`)."""


def _bake_waves(todo: list[dict], bake_wave) -> list[dict]:
    """Bake ``todo`` with ``bake_wave`` (a wave's assets → their records), in waves: the
    assets of distinct work (:func:`same_work`), then their copies, then the exports
    (which read the ``env_sh`` assets); the records."""
    first, copies = same_work([a for a in todo if a["kind"] != "export"])
    results = bake_wave(first)
    outputs = {a["id"]: a["output"] for a in first}
    copy_of = {r["id"]: {"output": outputs[r["id"]]} | {k: r[k] for k in COPIED_RECORD}
               for r in results if r["id"] in copies}  # fmt: skip
    wave = [dict(a, copy_of=copy_of[aid]) for aid, same in copies.items() for a in same]
    results += bake_wave(wave) if wave else []
    return results + bake_wave([a for a in todo if a["kind"] == "export"])


def _staged_bytes(path: str) -> bytes:
    with open(staged(path), "rb") as f:
        return f.read()


def _with_inputs(rec, path):
    """Lock record ``rec`` with each input's path (a key of ``inputs``) mapped by ``path``;
    anything that is not a record as it is (:func:`_poisoned` judges it)."""
    if not (isinstance(rec, dict) and isinstance(rec.get("inputs"), dict)):
        return rec
    return dict(rec, inputs={path(p): h for p, h in rec["inputs"].items()})


def _poisoned(asset: dict, rec) -> bool:
    """Whether lock record ``rec`` of ``asset`` cannot be trusted: not a record, or an output
    outside the asset's folder (symbolic links resolved) or not a regular file (a FIFO,
    ``/dev/zero``, a folder or a link would block, never end or fail the hash)."""
    if not (isinstance(rec, dict) and isinstance(rec.get("inputs"), dict)
            and isinstance(rec.get("outputs"), dict)):  # fmt: skip
        return True
    base = os.path.dirname(asset["output"])
    for rel, digest in rec["outputs"].items():
        path = os.path.join(base, rel)
        # a plain name is in the folder unless it is a link (refused below): no realpath
        plain = rel not in ("", ".", "..") and os.sep not in rel
        if not isinstance(digest, str) or os.path.isabs(rel) or not (
                plain or is_inside(path, base)):  # fmt: skip
            return True
        try:
            mode = os.lstat(path).st_mode
        except OSError:
            continue  # missing: out of date, not poisoned
        if not stat.S_ISREG(mode):
            return True
    return False


def _up_to_date(asset: dict, rec: dict | None) -> bool:
    """Whether ``asset`` matches its lock record (not :func:`_poisoned`): same plan key and
    settings, same inputs' and outputs' bytes."""
    if not rec or (rec.get("plan_key"), rec.get("settings")) != (
        asset["plan_key"],
        asset["settings"],
    ):
        return False
    if any(not os.path.exists(p) or file_hash(p) != rec["inputs"].get(p) for p in asset["inputs"]):
        return False
    base = os.path.dirname(asset["output"])
    return all(os.path.exists(os.path.join(base, r))
               and file_hash(os.path.join(base, r), own_output=True) == h
               for r, h in rec["outputs"].items())  # fmt: skip


STATE_MAX_BYTES = 64 << 20
"""Largest lock or stamp file read back."""


def _read_state(path: str) -> str | None:
    """The text of a lock or stamp file, ``None`` if it is missing, unreadable or not a
    regular file (a FIFO in the out_dir must not block the bake)."""
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode) or st.st_size > STATE_MAX_BYTES:
            return None
        with open(path, encoding="utf-8") as f:
            return f.read(STATE_MAX_BYTES)
    except (OSError, ValueError):
        return None


def _read_json(path: str):
    """The JSON value of a lock or stamp file, ``None`` if it is missing, not a regular file
    or not JSON (nested too deep included)."""
    text = _read_state(path)
    try:
        return json.loads(text) if text is not None else None
    except (ValueError, RecursionError):
        return None


def lock_text(lock: dict) -> str:
    """``lock`` as JSON, one line per asset record and per unit plan (keys sorted): as
    readable and diffable as an indented file, written by json's C encoder (an indented
    dump is pure Python: ~5 s for a 1000-map lock)."""
    lines = ["{"]
    for i, (key, value) in enumerate(sorted(lock.items())):
        end = "," if i < len(lock) - 1 else ""
        if isinstance(value, dict) and value:
            rows = [f"  {json.dumps(k)}: {json.dumps(v, sort_keys=True)}"
                    for k, v in sorted(value.items())]  # fmt: skip
            lines.append(f" {json.dumps(key)}: {{\n" + ",\n".join(rows) + f"\n }}{end}")
        else:
            lines.append(f" {json.dumps(key)}: {json.dumps(value, sort_keys=True)}{end}")
    return "\n".join(lines + ["}"]) + "\n"


@path_arguments("path")
def read_lock(path: str) -> dict:
    """The lock at ``path``; ``{}`` if it is missing or not a lock (an object whose
    ``assets`` and ``plans`` are objects)."""
    lock = _read_json(path)
    if not isinstance(lock, dict) or not all(isinstance(lock.get(k, {}), dict)
                                             for k in ("assets", "plans")):  # fmt: skip
        return {}
    return lock


def write_stamps(plan: dict, scene: Scene) -> list[str]:
    """Write each asset's settings stamp, only where its JSON value changed (make sees no
    change otherwise), paths relative to the scene's folder
    (:mod:`shbake.batch.scene_paths`). Returns the stamps written."""
    written = []
    for a in plan["assets"]:
        path = stamp_path(plan["out_dir"], a["id"])
        stored = stored_asset(a, scene)
        if _same_stamp(_read_state(path), stored):
            continue
        makedirs(os.path.dirname(path))
        write_text(path, settings_text(stored))
        written.append(path)
    return written


def _same_stamp(text: str | None, asset: dict) -> bool:
    """Whether the stamp ``text`` holds the value :func:`settings_text` writes for ``asset``:
    compared as compact JSON (json's C encoder; ``settings_text`` indents, which only the
    pure-Python encoder does: ~1 s of a no-op bake of 2000 assets); the types of numbers
    kept (``1`` is not ``1.0``)."""
    if text is None:
        return False
    try:
        value = json.loads(text)
    except (ValueError, RecursionError):
        return False
    return json.dumps(value, sort_keys=True) == json.dumps(settings_value(asset), sort_keys=True)


def declare_outputs(plan: dict) -> None:
    """Refuse, before any work, an output of ``plan`` (an asset, its settings stamp) that is
    an input of the run (:func:`shbake.resources.declare_output`: the same path, or the same
    file through a symbolic or hard link) or that a symbolic link takes out of its
    ``out_dir`` (:func:`declare_in_out_dir`)."""
    for a in plan["assets"]:
        declare_in_out_dir(a["output"], plan["out_dir"])
        declare_in_out_dir(stamp_path(plan["out_dir"], a["id"]), plan["out_dir"])


def declare_in_out_dir(path: str, out_dir: str) -> None:
    """Declare the output ``path`` (:func:`shbake.resources.declare_output`), refused if it
    is not inside ``out_dir`` once symbolic links are resolved (a linked subfolder of the
    scene's ``out_dir`` must not carry its writes elsewhere)."""
    if not is_inside(path, out_dir):
        raise OutputError(f"{path}: a symbolic link takes it out of the scene's out_dir "
                          f"{out_dir} (shbake writes only inside it)")  # fmt: skip
    resources.declare_output(path)


def _stamped_asset(scene: Scene, aid: str) -> dict:
    """Asset ``aid`` as its settings stamp holds it, refused unless the stamp is one that
    :func:`write_stamps` could have written for ``scene`` (its output where ``aid``'s is,
    its inputs the scene's maps, MERL files and ``env_sh`` assets)."""
    if not re.fullmatch(ASSET_ID, aid):
        raise ParameterError(f"--asset {aid!r}: not an asset id (KIND/NAME…, as shbake plan "
                             "lists them)")  # fmt: skip
    path = stamp_path(scene.out_dir, aid)
    asset = _read_json(path)
    if asset is None:
        raise ParameterError(f"{path}: no settings stamp for {aid!r}; run shbake plan "
                             "--emit-make first")  # fmt: skip
    resources.note_input(path)
    allowed = {e.map for e in scene.environments} | {m.merl for m in scene.materials if m.merl}
    allowed |= {asset_output(scene.out_dir, f"env_sh/{e.name}") for e in scene.environments}
    kind = aid.split("/")[0]
    if (
        isinstance(asset, dict)
        and isinstance(asset.get("output"), str)
        and isinstance(asset.get("inputs"), list)
        and all(isinstance(p, str) for p in asset["inputs"])
    ):
        base = scene_folder(scene)  # the stamp's paths are relative to the scene's folder
        asset = dict(asset, output=resolved(asset["output"], base),
                     inputs=[resolved(p, base) for p in asset["inputs"]])  # fmt: skip
    if not (isinstance(asset, dict) and asset.get("id") == aid and asset.get("kind") == kind
            and kind in BAKERS and asset.get("output") == asset_output(scene.out_dir, aid)
            and isinstance(asset.get("settings"), dict) and isinstance(asset.get("inputs"), list)
            and all(isinstance(p, str) and os.path.abspath(p) in allowed
                    for p in asset["inputs"])):  # fmt: skip
        raise ParameterError(f"{path}: not a settings stamp of {aid!r} for {scene.path}; run "
                             "shbake plan --emit-make again")  # fmt: skip
    return asset


def _out_of_date(asset: dict) -> bool:
    """make's rule for one asset of a grouped rule: its output is missing or older than one
    of its inputs or its settings stamp."""
    try:
        built = os.stat(asset["output"]).st_mtime_ns
    except OSError:
        return True
    deps = [*asset["inputs"], asset["stamp"]]
    return any(os.stat(p).st_mtime_ns > built for p in deps if os.path.exists(p))


def _bake_stamped(scene: Scene, ids: list[str]) -> dict:
    """Bake assets ``ids`` from their settings stamps, in this process (what the fragment's
    recipes run): one id unconditionally (make decided); several — a rule of several maps'
    assets (:func:`emit_make` with ``maps_per_rule``) — those out of date by make's own rule
    (:func:`_out_of_date`), so a rule's recipe rebakes exactly what changed; each map
    decoded once."""
    from shbake.envmap.environment import decoded_once

    assets = []
    for aid in dict.fromkeys(ids):
        asset = _stamped_asset(scene, aid)
        full = dict(asset, plan_key="", tolerances={}, predicted_error={}, predicted_seconds=0.0,
                    stamp=stamp_path(scene.out_dir, aid))  # fmt: skip
        declare_in_out_dir(full["output"], scene.out_dir)
        assets.append(full)
    todo = assets if len(assets) == 1 else [a for a in assets if _out_of_date(a)]
    with decoded_once():
        records = {a["id"]: bake_asset(a, measure=False) for a in todo}
    return {"baked": list(records), "skipped": [a["id"] for a in assets if a["id"] not in records],
            "records": records, "warnings": []}  # fmt: skip


def bake_scene(scene: Scene, jobs: int = 1, scheduler=None,
               only: str | list[str] | None = None, progress=None,
               connect_timeout: float = CONNECT_SECONDS) -> dict:  # fmt: skip
    """Plan ``scene`` and bake what is out of date; the summary (baked, skipped, records,
    ``warnings``: lock records that could not be trusted and were baked again).

    ``only``: bake just this asset id (or these ids, :func:`_bake_stamped`) from its stamp
    (what the make rules run); the lock is then left alone (make's own timestamps track it).

    Inputs are never outputs: the scene, its maps and MERL files are the run's inputs
    (:func:`~shbake.batch.scene.load_scene`), the lock and every planned output are
    declared before any work and refused if one is an input; a bake then reads back only
    its own outputs (measured errors, exports of its ``env_sh`` assets).

    ``scheduler``: a Dask scheduler address, connected before planning (within
    ``connect_timeout`` seconds, :func:`shbake.batch.scheduler.session`), or a connected
    client; the workers' outputs are written here and committed with the lock, all
    together or not at all (:func:`_bake_on_scheduler`).
    """
    from shbake.batch.scheduler import session

    if isinstance(scheduler, str):  # connected before planning; the run is all or nothing
        with session(scheduler, connect_timeout) as client, transaction():
            return bake_scene(scene, jobs, client, only, progress)
    if only is not None:
        return _bake_stamped(scene, [only] if isinstance(only, str) else list(only))
    lock_file = lock_path(scene)
    resources.declare_output(lock_file)  # read, then replaced: no input may be the lock
    lock = read_lock(lock_file)
    # per-unit plans (measured once), filled by the plan
    units = {k: v for k, v in lock.get("plans", {}).items() if isinstance(v, dict)}
    plan = plan_scene_kept(scene, cache=units, jobs=1 if scheduler is not None else jobs)
    declare_outputs(plan)
    resources.outputs_declared()
    base = scene_folder(scene)  # the lock's input paths are relative to it
    previous = {aid: _with_inputs(rec, lambda p: resolved(p, base))
                for aid, rec in lock.get("assets", {}).items()}  # fmt: skip
    poisoned = [a["id"] for a in plan["assets"]
                if a["id"] in previous and _poisoned(a, previous[a["id"]])]  # fmt: skip
    todo = [a for a in plan["assets"]
            if a["id"] in poisoned or not _up_to_date(a, previous.get(a["id"]))]  # fmt: skip
    ids = {a["id"] for a in todo}
    todo += [a for a in plan["assets"] if a["kind"] == "export" and a["id"] not in ids
             and a["settings"]["env_sh"] in ids]  # fmt: skip
    todo = [_with_planned(a, units) for a in todo]
    if scheduler is None and jobs > 1 and len(todo) > 1:
        start_server()  # it warms while the stamps are written
    makedirs(scene.out_dir)
    write_stamps(plan, scene)  # before the assets: make then finds each newer than its stamp
    if scheduler is not None:
        results = _bake_waves(todo, lambda wave: _bake_on_scheduler(scheduler, wave))
    elif jobs > 1 and len(todo) > 1:
        with worker_pool(jobs) as pool:  # one pool: its workers stay warm across waves
            results = _bake_waves(todo, lambda wave: [
                r for task in pool.map(bake_chunk, chunks(wave)) for r in task])  # fmt: skip
    else:
        results = _bake_waves(todo, lambda wave: [
            r for task in chunks(wave) for r in bake_chunk(task)])  # fmt: skip
    records = {a["id"]: previous[a["id"]] for a in plan["assets"]
               if a["id"] in previous and a["id"] not in poisoned}  # fmt: skip
    for r in results:
        records[r["id"]] = r
    keep = scene.written_absolute
    new_lock = {
        "scene": os.path.basename(scene.path),
        "assets": {
            aid: _with_inputs(rec, lambda p: stored(p, base, keep))
            for aid, rec in sorted(records.items())
        },  # fmt: skip
        "plans": {k: units[k] for k in sorted(units)},  # the units the plan read
    }
    with atomic_path(lock_file) as tmp, open(tmp, "w") as f:
        f.write(lock_text(new_lock))
    done = {r["id"] for r in results}
    warnings = []
    if poisoned:
        warnings.append(
            f"{lock_file}: ignored the records of {', '.join(poisoned)} (an output "
            "outside its asset's folder or not a regular file); baked them again"
        )
    return {"baked": [r["id"] for r in results],
            "skipped": [a["id"] for a in plan["assets"] if a["id"] not in done],
            "records": records, "lock": lock_file, "warnings": warnings}  # fmt: skip


def _with_planned(asset: dict, units: dict) -> dict:
    """``asset`` with what its plan unit made of the map that the bake would make again:
    an SH-exp probe's fit (``planned_fit``, :func:`shbake.batch.plan.plan_shexp`), an
    ``env_sh`` asset's projection (``planned_projection``, its sun extracted,
    :func:`shbake.batch.plan.plan_env_sh`) — of the same map bytes at the same settings,
    made by the calls the bake makes (the same bits), so the bake writes them instead.
    Not a fit for a turned probe (the plan fits the map unturned; a projection is turned
    with the SH) nor a projection with fitted lights. The unit may come from the lock or
    the plan cache: ``from_record`` checks it (:meth:`ShexpProbe.from_record`,
    :meth:`Projection.from_record`), and the bake makes its own when it is not one."""
    unit = units.get(asset["plan_key"], {})
    if asset["kind"] == "shexp" and "fit" in unit:
        turned = float(asset["settings"].get("pose", {}).get("rotation_deg", 0.0)) % 360.0
        return asset if turned else dict(asset, planned_fit=unit["fit"])
    if asset["kind"] == "env_sh" and "projection" in unit and "lights" not in asset["settings"]:
        return dict(asset, planned_projection=unit["projection"])
    return asset


def check_makeable(scene: Scene, fragment: str, shbake: str = "shbake") -> None:
    """Refuse, before planning, a scene a Makefile fragment cannot name exactly
    (:mod:`shbake.batch.makefile`) as the fragment names it (:func:`fragment_path`): its
    file, its maps and MERL files, its ``out_dir`` (:class:`~shbake.batch.scene.SceneError`:
    FILE:LINE: KEY), the fragment's path or the ``shbake`` command
    (:class:`~shbake.batch.makefile.MakeNameError`, naming the option)."""
    here = os.path.dirname(os.path.abspath(fragment))
    named = [(scene.path, "(file)"), (os.path.join(scene.out_dir, STAMP_DIR), "scene.out_dir")]
    named += [(e.map, f"{e.key}.map") for e in scene.environments]
    named += [(m.merl, f"{m.key}.merl") for m in scene.materials if m.merl]
    for path, key in named:
        try:
            make_path(fragment_path(path, here, scene.written_absolute))
        except MakeNameError as e:
            raise scene.error(key, f"{e.reason}: {e.text!r} (shbake bake takes it)") from None
    try:
        make_path(fragment_path(fragment, here))
    except MakeNameError as e:
        raise MakeNameError(e.text, e.reason, "--emit-make") from None
    if os.path.basename(fragment) == "-":  # make -f - and include - read standard input
        raise MakeNameError(fragment, "make reads a makefile named '-' from standard input",
                            "--emit-make")  # fmt: skip
    _shbake_words(shbake)


def fragment_path(path: str, here: str, written_absolute=frozenset()) -> str:
    """``path`` as the fragment in folder ``here`` names it, for make run there: relative to
    ``here`` (:func:`~shbake.batch.scene_paths.stored`), absolute where the scene wrote it
    so; ``./`` before a relative name starting with ``-`` or ``~`` (an option to ``sh``'s
    command, a library or a home folder to make)."""
    text = stored(os.path.abspath(path), here, written_absolute)
    return "./" + text if text[0] in "-~" else text


def _shbake_words(shbake: str) -> list[str]:
    """The words of ``--shbake`` as ``sh`` splits them, refused unless a Makefile holds them."""
    try:
        words = shlex.split(shbake)
    except ValueError as e:
        raise MakeNameError(shbake, f"not a command ({e})", "--shbake") from None
    if not words:
        raise MakeNameError(shbake, "not a command (empty)", "--shbake")
    try:
        variable_value(words)
        shell_word(shbake)
    except MakeNameError as e:
        raise MakeNameError(e.text, e.reason, "--shbake") from None
    return words


@path_arguments("path")
def emit_make(scene: Scene, plan: dict, path: str, shbake: str = "shbake",
              maps_per_rule: int = 1) -> str:  # fmt: skip
    """Write the Makefile fragment of ``plan`` to ``path`` and the settings stamps
    (together: one transaction); its text.

    One rule per asset: it depends on its inputs (maps, MERL files, an export's
    ``env_sh`` asset) and on its settings stamp, which :func:`write_stamps`
    rewrites only when the asset's settings change, so a changed tolerance
    rebuilds only what it affects. The fragment remakes itself (and the stamps)
    when the scene file changes or ``$(SHBAKE) --version`` is not the version that wrote
    it (asked once each time make reads it); GNU make then restarts with the new rules,
    and the remade fragment keeps ``--shbake``. Its paths are relative to its own folder,
    where make runs (``include`` it from a Makefile there), absolute only where the scene
    wrote them so (:func:`fragment_path`): a scene folder moves with its fragment.
    Every file name, word and value in it is written by :mod:`shbake.batch.makefile`
    (after :func:`check_makeable`): make and ``sh`` read back exactly the paths and
    names given, and run ``$(SHBAKE)`` with exactly the arguments given, nothing else.

    ``maps_per_rule`` > 1: one rule (GNU make ≥ 4.3 grouped targets, ``&:``) for the assets
    of that many maps (:func:`chunks`; exports keep a rule each), one process per rule; its
    recipe names every asset of the rule and rebakes those out of date by make's own rule
    (:func:`_bake_stamped`), so incremental rebuilds stay exact per asset.
    """
    check_makeable(scene, path, shbake)
    here = os.path.dirname(os.path.abspath(path))

    def named(p: str) -> str:
        return fragment_path(p, here, scene.written_absolute)

    scene_path, frag = named(scene.path), named(path)
    flags = [] if is_inside(scene.out_dir, scene_folder(scene)) else ["--allow-outside"]

    def recipe(*words: str) -> str:
        return "\t$(SHBAKE) " + " ".join(shell_word(w) for w in words)

    prefix = f"SCENE_{variable_name(scene.name)}"
    grouped = ["--maps-per-rule", str(maps_per_rule)] if maps_per_rule > 1 else []
    plan_flags = [*flags, *grouped, "--quiet"]
    lines = [
        "# generated by shbake plan --emit-make: one rule per asset of the scene (do not edit)",
        ".DELETE_ON_ERROR:",
        f"SHBAKE ?= {variable_value(_shbake_words(shbake))}",
        f"{prefix}_ASSETS = " + " ".join(make_path(named(a["output"])) for a in plan["assets"]),
        ".PHONY: scene-assets",
        f"scene-assets: $({prefix}_ASSETS)",
        "",
        f"# written by shbake {__version__}: another version plans again",
        f"ifneq ($(lastword $(shell $(SHBAKE) --version 2>/dev/null)),{__version__})",
        f".PHONY: {prefix}_SHBAKE_CHANGED",
        f"{line_start_path(frag)} : {prefix}_SHBAKE_CHANGED",
        "endif",
        f"{line_start_path(frag)} : {make_path(scene_path)}",
        recipe("plan", scene_path, "--emit-make", frag, "--shbake", shbake, *plan_flags),
        "",
    ]
    groups = [[a] for a in plan["assets"]]
    if maps_per_rule > 1:
        groups = chunks([a for a in plan["assets"] if a["kind"] != "export"], maps_per_rule)
        groups += [[a] for a in plan["assets"] if a["kind"] == "export"]
    for group in groups:
        deps = [named(p) for a in group for p in a["inputs"]]
        deps += [named(stamp_path(plan["out_dir"], a["id"])) for a in group]
        targets = " ".join(make_path(named(a["output"])) for a in group)
        ids = [w for a in group for w in ("--asset", a["id"])]
        lines += [
            f"{targets} {'&:' if len(group) > 1 else ':'} "
            + " ".join(make_path(p) for p in dict.fromkeys(deps)),
            recipe("bake", scene_path, *ids, *flags, "--quiet"),
            "",
        ]
    text = "\n".join(lines)
    check_output_path(path, "--emit-make")
    if written_by_shbake(path, scene.out_dir) is not None:
        raise OutputError(f"{path}: is in {scene.out_dir}, which the scene's bake writes "
                          "(--emit-make must name another file)")  # fmt: skip
    declare_outputs(plan)
    write_stamps(plan, scene)
    write_text(path, text)
    return text


def format_bake(summary: dict) -> str:
    """One line per baked asset (measured error vs tolerance, measured vs predicted time)."""
    lines = []
    for aid in summary["baked"]:
        r = summary["records"][aid]
        err = ", ".join(
            f"{k} {v:.3g}" + (f" (tol {r['tolerances'][k]:g})" if k in r["tolerances"] else "")
            for k, v in r["measured_error"].items()
        )
        pred = r["predicted_seconds"]
        pred = "" if pred is None else f"; its make recipe: {pred:.2f} CPU s predicted"
        lines.append(f"baked {aid}: {err or 'no error model'}; {r['bake_seconds']:.2f} s warm "
                     f"in this process{pred}")  # fmt: skip
    lines.append(f"bake: {len(summary['baked'])} baked, {len(summary['skipped'])} up to date")
    return "\n".join(lines)
