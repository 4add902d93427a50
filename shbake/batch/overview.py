"""``shbake overview`` as one unit of work: read a folder's summaries and scene locks, write
one page that judges them (:mod:`shbake.preview.overview` renders it).

What the folder holds, all of it untrusted (``docs/SECURITY.md``):

* bake summaries (``project-env --json > NAME.json``): the asset, its settings, its error
  against brute force, its bytes and bake seconds, the sun or fitted lights;
* probe batches (``probe-fit --json > NAME.json``): each probe's headline error and bytes;
* preview summaries (``preview --json > NAME.json``): a contact sheet and its error;
* scene locks (``scene.lock.json`` in the folder or one folder below it, ``shbake bake``):
  per asset its measured errors, the scene's tolerances, outputs and bake seconds;
* tradeoff plots (``tradeoff*.png``, ``shbake tradeoff``; not a ``…-sheet.png``, a preview's).

Every summary's and record's fields must have the types the commands write (a finite
number, a string, a list of strings); a file or record that does not is skipped, as a
file that is not JSON is. Each measured error becomes a row of the summary table with its
tolerance (the scene's; else ``--tol``) and a verdict. Rows, groups and cards are sorted
by name, so the same folder gives the same bytes.
"""

import json
import math
import os
import stat
from pathlib import Path

from shbake.batch.scene import LOCK_NAME, asset_output, is_inside
from shbake.errors import InputError
from shbake.evaluation.metrics import HEADLINE_WARNING
from shbake.format.atomic import write_text
from shbake.preview.overview import render_page
from shbake.resources import path_arguments, read_bounded

SUMMARY_MAX_BYTES = 1 << 20
"""Largest ``--json`` summary file read."""
LOCK_MAX_BYTES = 64 << 20
"""Largest scene lock read (as ``shbake bake`` reads its own)."""
DEFAULT_TOLERANCE = 0.05
"""The tolerance of an error that neither its summary, ``--tol`` nor a warning limit of its
kind (:data:`~shbake.evaluation.metrics.HEADLINE_WARNING`) names: 5 % relative."""


def limit_of(kind: str, tol: float | None) -> tuple[float, str]:
    """The tolerance of an error of an asset ``kind`` (or ``preview of`` one) whose summary
    names none, and where it comes from: ``tol`` (``--tol``) when given, else the limit at
    which the command baking that kind warns, else :data:`DEFAULT_TOLERANCE`."""
    if tol is not None:
        return tol, "--tol"
    limit = HEADLINE_WARNING.get(kind.removeprefix("preview of "))
    return (DEFAULT_TOLERANCE, "default") if limit is None else (limit, "warning limit")
PREVIEW_NUMBERS = ("roughness", "f0", "relative_rms_error", "mse", "fps", "error_beyond_scale")
"""The preview summary fields the page shows as numbers (finite reals in a summary)."""


def _number(x) -> bool:
    """A finite real (JSON number, not a boolean)."""
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _strings(x) -> bool:
    return isinstance(x, list) and all(isinstance(p, str) for p in x)


def _optional(summary: dict, key: str, check) -> bool:
    return key not in summary or check(summary[key])


def is_preview(summary) -> bool:
    """Whether ``summary`` has the types ``preview --json`` writes (where it has a field)."""
    if not isinstance(summary, dict) or not _strings(summary.get("outputs", [])):
        return False
    if not all(_optional(summary, k, lambda v: isinstance(v, str))
               for k in ("pass", "asset", "kind", "display")):  # fmt: skip
        return False
    size = summary.get("size", 1)
    if isinstance(size, bool) or not isinstance(size, int) or size < 1:
        return False
    return all(_optional(summary, k, _number) for k in PREVIEW_NUMBERS)


def _is_sun(sun) -> bool:
    if not isinstance(sun, dict) or not isinstance(sun.get("extracted", False), bool):
        return False

    def vector(v):
        return isinstance(v, list) and len(v) == 3 and all(_number(c) for c in v)

    def radius(r):  # a sphere light's, degrees: [0, 90)
        return _number(r) and 0.0 <= r < 90.0

    numbers = ("intensity", "elevation_deg", "azimuth_deg", "contrast")
    return (all(_optional(sun, k, vector) for k in ("direction", "colour"))
            and all(_optional(sun, k, _number) for k in numbers)
            and _optional(sun, "angular_radius_deg", radius))  # fmt: skip


def _is_lights(lights) -> bool:
    """``--lights``' summary: its ``lights``, each as a sun's fields (:func:`_is_sun`)."""
    found = lights.get("lights", []) if isinstance(lights, dict) else None
    return isinstance(found, list) and all(_is_sun(x) for x in found)


def _is_errors(errors) -> bool:
    return isinstance(errors, dict) and all(
        isinstance(e, dict) and _number(e.get("mean")) for e in errors.values()
    )


def is_bake(summary) -> bool:
    """Whether ``summary`` has the types a bake's ``--json`` writes: its ``output`` and
    ``outputs``; optionally ``kind``, ``lmax``, ``irradiance_lmax``, ``window``,
    ``bake_seconds``, ``sun``, ``lights``, ``report.error_vs_brute_force`` and ``error`` (the
    headline:
    ``{"quantity", "value"}``)."""
    if not (isinstance(summary, dict) and isinstance(summary.get("output"), str)
            and _strings(summary.get("outputs"))):  # fmt: skip
        return False
    if not all(_optional(summary, k, lambda v: isinstance(v, str))
               for k in ("kind", "window", "input", "target")):  # fmt: skip
        return False
    ints = all(_optional(summary, k, lambda v: isinstance(v, int) and not isinstance(v, bool))
               for k in ("lmax", "irradiance_lmax"))  # fmt: skip
    report = summary.get("report", {})
    return (ints and _optional(summary, "bake_seconds", _number)
            and _optional(summary, "sun", _is_sun) and _optional(summary, "lights", _is_lights)
            and isinstance(report, dict)
            and _optional(report, "error_vs_brute_force", _is_errors)
            and _optional(summary, "error", lambda e: e is None or _is_headline(e)))  # fmt: skip


def _is_headline(error) -> bool:
    return (isinstance(error, dict) and isinstance(error.get("quantity"), str)
            and _number(error.get("value")))  # fmt: skip


def is_probe_batch(summary) -> bool:
    """Whether ``summary`` has the types ``probe-fit --json`` writes: ``probes``, each with
    its ``source``, ``output`` and headline ``error``; ``seconds`` for the batch."""
    probes = summary.get("probes") if isinstance(summary, dict) else None
    return (isinstance(probes, list) and bool(probes) and _optional(summary, "seconds", _number)
            and all(isinstance(p, dict) and isinstance(p.get("output"), str)
                    and isinstance(p.get("source"), str) and _is_headline(p.get("error"))
                    for p in probes))  # fmt: skip


def _read_json(path: Path, limit: int, what: str):
    try:
        return json.loads(read_bounded(str(path), limit, what))
    except (OSError, ValueError, RecursionError):  # unreadable, special, too large, not JSON
        return None


def file_bytes(path: str) -> int | None:
    """Size of a regular file (a link or special file is not measured: ``None``)."""
    try:
        st = os.lstat(path)
    except OSError:
        return None
    return st.st_size if stat.S_ISREG(st.st_mode) else None


def _bake_setting(s: dict) -> str:
    parts = [f"{k.replace('_', ' ')} {s[k]}" for k in ("target", "lmax", "irradiance_lmax",
                                                        "window") if k in s]  # fmt: skip
    sun = s.get("sun")
    if sun is not None:
        parts.append("sun extracted" if sun.get("extracted") else "no sun extracted")
    return ", ".join(parts)


def _row(asset, href, kind, setting, quantity, error, tolerance, source, size, seconds) -> dict:
    return {"asset": asset, "href": href, "kind": kind, "setting": setting,
            "quantity": quantity, "error": error, "tolerance": tolerance,
            "tolerance_from": source, "verdict": None if error is None else error <= tolerance,
            "bytes": size, "seconds": seconds}  # fmt: skip


def _bake_rows(stem: str, s: dict, tol: float | None) -> list[dict]:
    """A bake summary's rows: its headline error (``error``) else each ``--report`` error
    (mean relative, against brute force); one row without an error when it has none."""
    size = file_bytes(s["output"])
    common = (s["output"], s["output"], s.get("kind", "asset"), _bake_setting(s))
    if s.get("error") is not None:
        errors = [(s["error"]["quantity"], s["error"]["value"])]
    else:
        found = s.get("report", {}).get("error_vs_brute_force", {})
        errors = [(f"{k}, mean relative", v["mean"]) for k, v in sorted(found.items())]
    errors = errors or [("not measured (no --report)", None)]
    limit = limit_of(common[2], tol)
    return [_row(*common, q, e, *limit, size, s.get("bake_seconds")) for q, e in errors]


def _probe_rows(s: dict, tol: float | None) -> list[dict]:
    """A ``probe-fit --json`` batch: one row per probe (its headline error, its file's
    bytes; the batch's seconds shared out evenly)."""
    seconds = s["seconds"] / len(s["probes"]) if "seconds" in s else None
    return [_row(p["output"], p["output"], "shexp_probe",
                 "fitted to " + os.path.basename(p["source"]), p["error"]["quantity"],
                 p["error"]["value"], *limit_of("shexp_probe", tol), file_bytes(p["output"]),
                 seconds)
            for p in s["probes"]]  # fmt: skip


def _preview_row(s: dict, tol: float | None) -> dict:
    asset = s.get("asset", "?")
    setting = ", ".join(x for x in (
        f"pass {s.get('pass', '?')}", f"{s['size']}²" if "size" in s else "",
        f"roughness {s['roughness']:g}" if "roughness" in s else "") if x)  # fmt: skip
    error = s.get("relative_rms_error")
    kind = f"preview of {s.get('kind', 'asset')}"
    return _row(asset, asset, kind, setting, "shaded sphere, relative RMS", error,
                *limit_of(kind, tol), None, None)  # fmt: skip


def _is_record(rec) -> bool:
    numbers = lambda d: isinstance(d, dict) and all(_number(v) for v in d.values())  # noqa: E731
    return (isinstance(rec, dict) and numbers(rec.get("measured_error", {}))
            and numbers(rec.get("tolerances", {})) and isinstance(rec.get("outputs"), dict)
            and all(isinstance(v, str) for v in rec["outputs"].values())
            and isinstance(rec.get("settings", {}), dict)
            and _optional(rec, "bake_seconds", _number))  # fmt: skip


def _lock_rows(lock_path: Path, tol: float | None) -> list[dict]:
    """The rows of a scene lock: one per measured error of each record (its scene
    tolerance), one per record measuring none; bytes of its outputs that are regular files
    inside the record's folder."""
    lock = _read_json(lock_path, LOCK_MAX_BYTES, "scene lock")
    if not isinstance(lock, dict) or not isinstance(lock.get("assets"), dict):
        return []
    out_dir = str(lock_path.parent)
    rows = []
    for aid, rec in sorted(lock["assets"].items()):
        if not _is_record(rec) or not aid or os.path.isabs(aid):
            continue
        output = asset_output(out_dir, aid)
        folder = os.path.dirname(output)
        if not is_inside(output, out_dir):
            continue
        paths = [os.path.join(folder, rel) for rel in rec["outputs"] if not os.path.isabs(rel)]
        sizes = [file_bytes(p) for p in paths if is_inside(p, folder)]
        size = sum(b for b in sizes if b is not None) if sizes else None
        settings = ", ".join(f"{k} {v}" for k, v in sorted(rec.get("settings", {}).items())
                             if isinstance(v, str | int | float | bool))  # fmt: skip
        common = (aid, output, aid.split("/")[0], settings)
        tolerances = rec.get("tolerances", {})
        measured = sorted(rec.get("measured_error", {}).items())
        seconds = rec.get("bake_seconds")
        for quantity, error in measured:
            own = quantity in tolerances
            limit, source = (tolerances[quantity], "scene") if own else limit_of(common[2], tol)
            rows.append(_row(*common, quantity, error, limit, source, size, seconds))
        if not measured:
            rows.append(_row(*common, "not measured", None, *limit_of(common[2], tol), size,
                             seconds))
    return rows


@path_arguments("folder")
def gather(folder: str, tol: float | None = None) -> dict:
    """What the page shows of ``folder``: ``rows`` of the summary table, ``groups`` (name →
    its ``previews`` ``(stem, summary)``, ``bakes`` and sheets without a summary) and the
    ``plots``."""
    root = Path(folder)
    if not root.exists():
        raise InputError(f"{folder}: does not exist")
    if not root.is_dir():
        raise InputError(f"{folder}: not a directory")
    rows, groups = [], {}

    def group(stem):
        return groups.setdefault(stem.split("-")[0], {"previews": [], "bakes": []})

    described = set()
    for path in sorted(root.glob("*.json")):
        if path.is_symlink():  # what the folder holds, not what its links point at
            continue
        summary = _read_json(path, SUMMARY_MAX_BYTES, "summary")
        if is_bake(summary):
            group(path.stem)["bakes"].append(summary)
            rows += _bake_rows(path.stem, summary, tol)
        elif is_probe_batch(summary):
            rows += _probe_rows(summary, tol)
        elif is_preview(summary):
            sheets = [p for p in summary.get("outputs", []) if p.endswith("-sheet.png")]
            if sheets:
                group(path.stem)["previews"].append((path.stem, summary | {"sheet": sheets[0]}))
                described.add(os.path.abspath(sheets[0]))
                if "relative_rms_error" in summary:
                    rows.append(_preview_row(summary, tol))
    rows.sort(key=lambda r: (r["asset"], r["kind"].startswith("preview of"), r["quantity"]))
    for sheet in sorted(root.glob("*-sheet.png")):
        if os.path.abspath(sheet) not in described:  # a sheet without a summary: its name only
            stem = sheet.name[: -len("-sheet.png")]
            group(stem)["previews"].append((stem, {"sheet": str(sheet)}))
    for lock in sorted([root / LOCK_NAME, *root.glob(f"*/{LOCK_NAME}")]):
        if lock.is_file() and not lock.is_symlink() and not lock.parent.is_symlink():
            rows += _lock_rows(lock, tol)
    # a tradeoff…-sheet.png is a preview's contact sheet (above), not a plot
    plots = [
        str(p) for p in sorted(root.glob("tradeoff*.png")) if not p.name.endswith("-sheet.png")
    ]
    return {"rows": rows, "groups": groups, "plots": plots}


@path_arguments("folder", "output")
def write_overview(folder: str, output: str, title: str = "shbake previews",
                   tol: float | None = None) -> dict:  # fmt: skip
    """Write the overview page of ``folder`` to ``output``; returns ``{"cards": n, ...}``
    (``failed``: the rows whose error exceeds their tolerance)."""
    page, counts = overview_page(folder, os.path.dirname(os.path.abspath(output)), title, tol)
    write_text(output, page)
    return {"output": output, **counts}


def overview_page(folder: str, base: str, title: str,
                  tol: float | None = None) -> tuple[str, dict]:  # fmt: skip
    """The page over ``folder`` for a file in the folder ``base`` (links are relative to it),
    and its counts (``cards``, ``groups``, ``rows``, ``failed``)."""
    found = gather(folder, tol)
    cards = sum(len(g["previews"]) for g in found["groups"].values())
    if not cards and not found["rows"]:
        raise InputError(f"{folder}: nothing to show (no *-sheet.png from 'shbake preview', "
                         "no --json summary, no scene.lock.json)")  # fmt: skip
    page = render_page(title, found["rows"], found["groups"], found["plots"], base, tol)
    failed = sum(1 for r in found["rows"] if r["verdict"] is False)
    return page, {"cards": cards, "groups": len(found["groups"]), "rows": len(found["rows"]),
                  "failed": failed}  # fmt: skip
