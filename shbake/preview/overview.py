"""One HTML page over a folder of previews: the page a person opens first after ``make demo``.

Every ``*.json`` in the folder that is a ``preview --json`` summary (it lists
its ``outputs``, one of them a ``-sheet.png`` contact sheet) becomes a card:
the contact sheet, the pass, the error against brute force and the speed; a
``-sheet.png`` without a summary becomes a card with its name only.
Cards are grouped by the asset's stem and sorted by name, so the same folder
gives the same bytes. Images are linked relatively: the page moves with the
folder.

The summaries and the file names are untrusted (``docs/SECURITY.md``): the page is
rendered by Jinja2 with autoescaping from the templates in ``templates/`` (package
data), so every value from a summary or a name is text, never markup. A summary
whose fields do not have the types ``preview --json`` writes is not a summary (skipped,
as a file that is not JSON is). A contact sheet is linked only when it is a file inside
the page's folder, by a percent-encoded relative URL (no scheme, no ``..``, no absolute
path can come from data); another is named in its card, not linked. A
``Content-Security-Policy`` meta allows images from the page's own origin and the
page's one style (by its SHA-256), nothing else: no script, no form, no ``<base>``.
"""

import base64
import functools
import hashlib
import json
import math
import os
from pathlib import Path
from urllib.parse import quote

from shbake.errors import InputError
from shbake.format.atomic import write_text
from shbake.resources import read_bounded

SUMMARY_MAX_BYTES = 1 << 20
"""Largest ``--json`` summary file read."""
NUMBERS = ("roughness", "f0", "relative_rms_error", "mse", "fps")
"""The summary fields the page shows as numbers (finite reals in a summary)."""


@functools.lru_cache(maxsize=1)
def _templates():
    """The autoescaping Jinja2 environment of ``templates/`` (imported on use: start-up)."""
    import jinja2

    return jinja2.Environment(
        loader=jinja2.PackageLoader("shbake.preview", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def content_security_policy(style: str) -> str:
    """The page's policy: images from its own origin (``file:`` too: a page opened from
    disk has an opaque origin some browsers do not match with ``'self'``), the one inline
    ``style`` by its SHA-256 (CSP Level 2 hash source), nothing else."""
    digest = base64.b64encode(hashlib.sha256(style.encode("utf-8")).digest()).decode("ascii")
    return (f"default-src 'none'; img-src 'self' file:; style-src 'sha256-{digest}'; "
            "base-uri 'none'; form-action 'none'")  # fmt: skip


def _is_summary(summary) -> bool:
    """Whether ``summary`` has the types ``preview --json`` writes (where it has a field)."""
    if not isinstance(summary, dict) or not isinstance(summary.get("outputs", []), list):
        return False
    if not all(isinstance(p, str) for p in summary.get("outputs", [])):
        return False
    if not isinstance(summary.get("pass", ""), str):
        return False
    size = summary.get("size", 1)
    if isinstance(size, bool) or not isinstance(size, int) or size < 1:
        return False
    return all(isinstance(summary.get(k, 0.0), int | float) and not isinstance(summary.get(k), bool)
               and math.isfinite(summary.get(k, 0.0)) for k in NUMBERS)  # fmt: skip


def _summaries(folder: Path) -> list[tuple[str, dict]]:
    out = []
    for path in sorted(folder.glob("*.json")):
        try:
            summary = json.loads(read_bounded(str(path), SUMMARY_MAX_BYTES, "preview summary"))
        except (OSError, ValueError):  # unreadable, special (FIFO), too large or not JSON
            continue
        if not _is_summary(summary):
            continue
        sheets = [p for p in summary.get("outputs", []) if p.endswith("-sheet.png")]
        if sheets:
            out.append((path.stem, summary | {"sheet": sheets[0]}))
    described = {os.path.abspath(s["sheet"]) for _, s in out}
    for sheet in sorted(folder.glob("*-sheet.png")):
        if os.path.abspath(sheet) not in described:  # a sheet without a summary: its name only
            out.append((sheet.name[: -len("-sheet.png")], {"sheet": str(sheet)}))
    return sorted(out, key=lambda card: card[0])


def relative_url(path: str, base: str) -> str | None:
    """The file ``path`` (relative to the working directory, or absolute) as a URL relative
    to the folder ``base``, each segment percent-encoded (``:`` included, so no scheme);
    ``None`` when it is not a file inside ``base``."""
    rel = os.path.relpath(os.path.abspath(path), base)
    parts = Path(rel).parts
    if os.path.isabs(rel) or not parts or ".." in parts or not os.path.isfile(path):
        return None
    return "/".join(quote(part, safe="") for part in parts)


def _card(stem: str, summary: dict, base: str) -> dict:
    """What the templates show of one card: text, numbers formatted, the link or ``None``."""
    src = relative_url(summary["sheet"], base)

    def num(key, spec, default=None):
        value = summary.get(key, default)
        return None if value is None else format(value, spec)

    return {
        "stem": stem, "src": src, "outside": None if src is not None else summary["sheet"],
        "pass": summary.get("pass"), "roughness": num("roughness", "g"), "f0": num("f0", "g", 1),
        "error": num("relative_rms_error", ".2%"), "mse": num("mse", ".3g"),
        "fps": num("fps", ".0f"), "size": summary.get("size"),
    }  # fmt: skip


def write_overview(folder: str, output: str, title: str = "shbake previews") -> dict:
    """Write the overview page of ``folder`` to ``output``; returns ``{"cards": n, ...}``."""
    page, cards, groups = overview_page(folder, os.path.dirname(os.path.abspath(output)), title)
    write_text(output, page)
    return {"output": output, "cards": cards, "groups": groups}


def overview_page(folder: str, base: str, title: str) -> tuple[str, int, int]:
    """The page over ``folder`` for a file in the folder ``base`` (links are relative to it),
    its number of cards and of groups."""
    root = Path(folder)
    if not root.is_dir():
        raise InputError(f"{folder}: not a directory")
    cards = _summaries(root)
    if not cards:
        raise InputError(f"{folder}: no contact sheets (*-sheet.png from 'shbake preview')")
    groups: dict[str, list] = {}
    for stem, summary in cards:
        groups.setdefault(stem.split("-")[0], []).append(_card(stem, summary, base))
    rows = [{"group": g, "pass": c["pass"], "error": c["error"]}
            for g in sorted(groups) for c in groups[g] if c["error"] is not None]  # fmt: skip
    from markupsafe import Markup

    env = _templates()
    style = Markup(env.loader.get_source(env, "overview.css")[0])  # package data: not escaped
    page = env.get_template("overview.html").render(
        title=title, style=style, csp=content_security_policy(style), rows=rows,
        groups=[{"name": g, "cards": groups[g]} for g in sorted(groups)],
    )  # fmt: skip
    return page, len(cards), len(groups)
