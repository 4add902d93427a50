"""One HTML page over a folder of previews: the page a person opens first after ``make demo``.

Every ``*.json`` in the folder that is a ``preview --json`` summary (it lists
its ``outputs``, one of them a ``-sheet.png`` contact sheet) becomes a card:
the contact sheet, the pass, the error against brute force and the speed; a
``-sheet.png`` without a summary becomes a card with its name only.
Cards are grouped by the asset's stem and sorted by name, so the same folder
gives the same bytes. Images are linked relatively: the page moves with the
folder.
"""

import html
import json
import os
from pathlib import Path

from shbake.errors import InputError
from shbake.format.atomic import write_text
from shbake.resources import read_bounded

STYLE = """
body { font-family: sans-serif; margin: 1.5em; background: #fafafa; color: #222; }
h1 { font-size: 1.4em; } h2 { font-size: 1.1em; margin-top: 1.6em; }
.cards { display: flex; flex-wrap: wrap; gap: 1em; }
.card { background: white; border: 1px solid #ddd; padding: 0.6em; max-width: 680px; }
.card img { max-width: 100%; display: block; }
.card p { margin: 0.3em 0 0; font-size: 0.85em; }
table { border-collapse: collapse; font-size: 0.85em; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
"""


SUMMARY_MAX_BYTES = 1 << 20
"""Largest ``--json`` summary file read."""


def _summaries(folder: Path) -> list[tuple[str, dict]]:
    out = []
    for path in sorted(folder.glob("*.json")):
        try:
            summary = json.loads(read_bounded(str(path), SUMMARY_MAX_BYTES, "preview summary"))
        except (OSError, ValueError):  # unreadable, special (FIFO), too large or not JSON
            continue
        if not isinstance(summary, dict):
            continue
        sheets = [p for p in summary.get("outputs", []) if str(p).endswith("-sheet.png")]
        if sheets:
            out.append((path.stem, summary | {"sheet": sheets[0]}))
    described = {os.path.abspath(s["sheet"]) for _, s in out}
    for sheet in sorted(folder.glob("*-sheet.png")):
        if os.path.abspath(sheet) not in described:  # a sheet without a summary: its name only
            out.append((sheet.name[: -len("-sheet.png")], {"sheet": str(sheet)}))
    return sorted(out, key=lambda card: card[0])


def _caption(summary: dict) -> str:
    if "pass" not in summary:
        return "no --json summary beside it"
    parts = [f"pass <b>{html.escape(str(summary.get('pass')))}</b>"]
    if "roughness" in summary:
        parts.append(f"roughness {summary['roughness']:g}, F0 {summary.get('f0', 1):g}")
    if "relative_rms_error" in summary:
        parts.append(
            f"relative RMS error vs brute force <b>{summary['relative_rms_error']:.2%}</b>, "
            f"MSE {summary['mse']:.3g}"
        )
    if "fps" in summary:
        parts.append(f"{summary['fps']:.0f} frames/s at {summary.get('size')}²")
    return "; ".join(parts)


def write_overview(folder: str, output: str, title: str = "shbake previews") -> dict:
    """Write the overview page of ``folder`` to ``output``; returns ``{"cards": n, ...}``."""
    root = Path(folder)
    if not root.is_dir():
        raise InputError(f"{folder}: not a directory")
    cards = _summaries(root)
    if not cards:
        raise InputError(f"{folder}: no contact sheets (*-sheet.png from 'shbake preview')")
    base = Path(os.path.abspath(os.path.dirname(os.path.abspath(output))))
    groups: dict[str, list] = {}
    for stem, summary in cards:
        groups.setdefault(stem.split("-")[0], []).append((stem, summary))
    rows = []
    body = [f"<h1>{html.escape(title)}</h1>",
            "<p>Each sheet: the asset's shading pass | the brute-force reference of the original "
            "map (one exposure) | the signed luminance error with its scale.</p>"]  # fmt: skip
    for group in sorted(groups):
        body.append(f"<h2>{html.escape(group)}</h2><div class='cards'>")
        for stem, summary in groups[group]:
            sheet = os.path.relpath(os.path.abspath(summary["sheet"]), base)
            body.append(
                f"<div class='card'><img src='{html.escape(sheet)}' alt='{html.escape(stem)}'>"
                f"<p>{html.escape(stem)}: {_caption(summary)}</p></div>"
            )
            if "relative_rms_error" in summary:
                rows.append((group, summary["pass"], summary["relative_rms_error"]))
        body.append("</div>")
    if rows:
        body.append("<h2>Error against brute force</h2><table><tr><th>map</th><th>pass</th>"
                    "<th>relative RMS error</th></tr>")  # fmt: skip
        for group, name, err in rows:
            body.append(f"<tr><td>{html.escape(group)}</td><td>{html.escape(str(name))}</td>"
                        f"<td>{err:.2%}</td></tr>")  # fmt: skip
        body.append("</table>")
    page = (
        "<!doctype html><html><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
        + "\n".join(body)
        + "</body></html>\n"
    )
    write_text(output, page)
    return {"output": output, "cards": len(cards), "groups": len(groups)}
