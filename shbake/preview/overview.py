"""The overview page: what a person opens first after ``make demo`` (HTML, no script).

:func:`render_page` draws what :mod:`shbake.batch.overview` gathered from a folder: FIRST
a summary table (asset, kind, setting, error against its tolerance with the verdict,
bytes, bake seconds), then the tradeoff plots, then one group per map (its stem): the
extracted sun (direction, colour, intensity), links to the asset and its exports, and
one card per preview (the contact sheet: result, reference, the signed error on the fixed
±10 % scale, the source map's thumbnail; :mod:`shbake.preview.contact_sheet`).

The summaries, locks and file names are untrusted (``docs/SECURITY.md``): the page is
rendered by Jinja2 with autoescaping from the templates in ``templates/`` (package
data), so every value from a summary or a name is text, never markup. A file is linked
only when it is a file inside the page's folder, by a percent-encoded relative URL (no
scheme, no ``..``, no absolute path can come from data); another is named, not linked. A
``Content-Security-Policy`` meta allows images from the page's own origin and the
page's one style (by its SHA-256), nothing else: no script, no form, no ``<base>``.
"""

import base64
import functools
import hashlib
import os
from pathlib import Path
from urllib.parse import quote

from shbake.preview.contact_sheet import ERROR_SCALE


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


def relative_url(path: str, base: str) -> str | None:
    """The file ``path`` (relative to the working directory, or absolute) as a URL relative
    to the folder ``base``, each segment percent-encoded (``:`` included, so no scheme);
    ``None`` when it is not a file inside ``base``."""
    rel = os.path.relpath(os.path.abspath(path), base)
    parts = Path(rel).parts
    if os.path.isabs(rel) or not parts or ".." in parts or not os.path.isfile(path):
        return None
    return "/".join(quote(part, safe="") for part in parts)


def _link(path: str | None, base: str) -> dict | None:
    """``{"name", "src"}`` of a file: ``src`` its relative URL and ``name`` its path relative
    to ``base`` when it is a file inside ``base``; else ``src`` ``None`` and the path as given
    (named only)."""
    if not path:
        return None
    src = relative_url(path, base)
    return {"name": path if src is None else os.path.relpath(os.path.abspath(path), base),
            "src": src}  # fmt: skip


def _percent(x) -> str | None:
    return None if x is None else format(x, ".2%")


def _table_row(r: dict, base: str) -> dict:
    verdict = {None: "—", True: "pass", False: "FAIL"}[r["verdict"]]
    link = _link(r["href"], base) or {"name": r["asset"], "src": None}
    name = link["name"] if r["asset"] == r["href"] else r["asset"]  # a path, or a lock's id
    return {"asset": {"name": name, "src": link["src"]}, "kind": r["kind"],
            "setting": r["setting"], "quantity": r["quantity"], "error": _percent(r["error"]),
            "tolerance": f"{r['tolerance']:.2%} ({r['tolerance_from']})", "verdict": verdict,
            "bytes": "—" if r["bytes"] is None else f"{r['bytes']:,}",
            "seconds": "—" if r["seconds"] is None else f"{r['seconds']:.2f}"}  # fmt: skip


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
        "beyond": num("error_beyond_scale", ".1%"), "display": summary.get("display"),
        "fps": num("fps", ".0f"), "size": summary.get("size"),
    }  # fmt: skip


def _sun(sun: dict | None) -> str | None:
    """The extracted sun in one line (direction, elevation, azimuth, colour, intensity)."""
    if not sun:
        return None
    if not sun.get("extracted"):
        contrast = sun.get("contrast")
        return "no sun extracted" + ("" if contrast is None else
                                     f" (peak/background contrast {contrast:.1f})")  # fmt: skip
    return "sun: " + _light(sun)


def _light(sun: dict) -> str:
    """A light (the sun, a fitted directional or sphere light): its fields in words."""
    vec = lambda v: "(" + ", ".join(f"{c:.3f}" for c in v) + ")"  # noqa: E731
    parts = [f"direction {vec(sun['direction'])}" if "direction" in sun else "",
             f"angular radius {sun['angular_radius_deg']:.2f}° (a sphere)"
             if "angular_radius_deg" in sun else "",
             f"elevation {sun['elevation_deg']:.1f}°" if "elevation_deg" in sun else "",
             f"azimuth {sun['azimuth_deg']:.1f}°" if "azimuth_deg" in sun else "",
             f"colour {vec(sun['colour'])}" if "colour" in sun else "",
             f"intensity {sun['intensity']:.4g} (irradiance at normal incidence, luminance)"
             if "intensity" in sun else ""]  # fmt: skip
    return ", ".join(p for p in parts if p)


def _group(name: str, group: dict, base: str) -> dict:
    bakes = [{"asset": _link(b["output"], base), "sun": _sun(b.get("sun")),
              "lights": [f"light {k + 1}: " + _light(x)
                         for k, x in enumerate(b.get("lights", {}).get("lights", []))],
              "files": [_link(p, base) for p in b["outputs"] if p != b["output"]]}
             for b in group["bakes"]]  # fmt: skip
    cards = [_card(stem, s, base) for stem, s in sorted(group["previews"], key=lambda c: c[0])]
    return {"name": name, "bakes": bakes, "cards": cards}


def render_page(title: str, rows: list[dict], groups: dict, plots: list[str], base: str,
                tol: float | None) -> str:  # fmt: skip
    """The page (links relative to the folder ``base``) over the summary ``rows``, the
    ``groups`` of bakes and previews and the tradeoff ``plots``
    (:func:`shbake.batch.overview.gather`); ``tol``: ``--tol``, the tolerance of rows without
    their own (else each row's kind's, :func:`shbake.batch.overview.limit_of`)."""
    from markupsafe import Markup

    env = _templates()
    style = Markup(env.loader.get_source(env, "overview.css")[0])  # package data: not escaped
    failed = sum(1 for r in rows if r["verdict"] is False)
    return env.get_template("overview.html").render(
        title=title, style=style, csp=content_security_policy(style),
        rows=[_table_row(r, base) for r in rows], failed=failed,
        tol=None if tol is None else f"{tol:.2%}",
        scale=f"{ERROR_SCALE:.0%}", plots=[_link(p, base) for p in plots],
        groups=[_group(g, groups[g], base) for g in sorted(groups)],
    )  # fmt: skip
