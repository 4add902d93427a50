"""The provenance block every asset carries (``docs/FORMAT.md`` §3).

``source_path`` is recorded relative to the asset's folder where possible, so a
folder of maps and assets can move as a whole and a probe baked on any runner
has the same bytes; :func:`resolve_source` finds the file again from the asset and
:func:`reload_source` reads it as the bake did (every recorded input policy).
"""

import functools
import os

from shbake import resources
from shbake.errors import FormatError, ImageReadError

MAP_META_KEYS = (
    "width", "height", "layout", "stored_format", "channels", "colorspace_in", "colorspace",
    "nonfinite_repaired", "negative_count", "negative_energy_change",
)  # fmt: skip
"""Keys of an environment's ``meta`` recorded as ``source_<key>`` besides the block."""
PROBE_META_KEYS = ("probe_position", "probe_rotation_deg")
"""Keys of a scene probe's pose in an environment's ``meta``, recorded as they are."""
NOT_IMAGE_FORMATS = ("null", "term")
"""OpenImageIO's pseudo-formats (no pixels in a file): not an image a map comes from."""


@functools.cache
def image_suffixes() -> tuple[str, ...]:
    """The file name endings (``.exr``, ``.hdr``, …; any case) a recorded ``source_path``
    must have to be followed: those of the image formats OpenImageIO reads, which every map
    shbake bakes is. An asset names an image, so it cannot make shbake open ``/etc/passwd``
    (docs/SECURITY.md §3)."""
    import OpenImageIO as oiio

    out = []
    for entry in oiio.get_string_attribute("extension_list").split(";"):
        fmt, _, exts = entry.partition(":")
        if fmt not in NOT_IMAGE_FORMATS:
            out += [f".{e.lower()}" for e in exts.split(",") if e]
    return tuple(out)


def no_source() -> dict:
    """The provenance block of an asset with no input file (an analytic BRDF table)."""
    return {
        "source_path": "",
        "source_sha256": "",
        "source_size": 0,
        "source_nonfinite_policy": "",
        "source_negative_policy": "",
    }


def file_source(path: str, sha256: str) -> dict:
    """The provenance block of a non-map input file (a MERL BRDF): path, size and
    ``sha256``, the SHA-256 of the bytes the bake read (``BRDF.source_sha256``)."""
    return no_source() | {
        "source_path": os.path.abspath(path),
        "source_sha256": sha256,
        "source_size": os.stat(path).st_size,
    }


def map_source(meta: dict) -> dict:
    """The provenance block of an environment map from its ``meta`` (``load_environment``)."""
    block = {
        "source_path": os.path.abspath(str(meta["path"])),
        "source_sha256": meta["sha256"],
        "source_size": int(meta["size"]),
        "source_nonfinite_policy": meta["nonfinite_policy"],
        "source_negative_policy": meta["negative_policy"],
    }
    block |= {k: meta[k] for k in PROBE_META_KEYS if k in meta}
    return block | {f"source_{k}": meta[k] for k in MAP_META_KEYS if k in meta}


def relativise(attrs: dict, asset_path: str) -> dict:
    """``attrs`` with ``source_path`` (and those of ``probe_sources``) relative to the folder
    of ``asset_path`` where possible (same file system root); absolute otherwise."""
    folder = os.path.dirname(os.path.abspath(asset_path))

    def rel(p):
        if not p or not os.path.isabs(p):
            return p
        try:
            return os.path.relpath(p, folder)
        except ValueError:  # another drive
            return p

    out = dict(attrs)
    if "source_path" in out:
        out["source_path"] = rel(out["source_path"])
    if isinstance(out.get("probe_sources"), list):
        out["probe_sources"] = [
            s | {"source_path": rel(s.get("source_path", ""))} for s in out["probe_sources"]
        ]
    return out


def resolve_source(attrs: dict, asset_path: str, given: str | None = None,
                   option: str = "--source") -> str:  # fmt: skip
    """The input file of an asset: ``given`` (the command's ``option``) if any, else
    ``source_path`` relative to the asset's folder. FIFOs, devices and folders are refused
    before opening, and a recorded path is followed only to an image
    (:func:`image_suffixes`). Raises :class:`ImageReadError` (not found) or
    :class:`FormatError`. Whether it holds the bytes the asset was baked from is checked
    on the bytes read (:func:`reload_source`).
    """
    recorded = attrs.get("source_path", "")
    if not isinstance(recorded, str):
        raise FormatError("attribute source_path must be a string")
    if given:
        resources.check_regular_file(given, option)
        return given
    if not recorded:
        raise ImageReadError(f"the asset records no source map; give it with {option}")
    if not recorded.lower().endswith(image_suffixes()):
        raise FormatError(f"recorded source map {recorded!r} is not named as an image "
                          f"file OpenImageIO reads; give it with {option}")  # fmt: skip
    path = os.path.join(os.path.dirname(os.path.abspath(asset_path)), recorded)
    if not os.path.exists(path):
        raise ImageReadError(
            f"source map {recorded!r} (recorded relative to the asset) not found at {path}; "
            f"give it with {option}"
        )
    resources.check_regular_file(path, "recorded source map")
    return path


def reload_source(asset, asset_path: str, given: str | None = None, option: str = "--source"):
    """The map ``asset`` was baked from, read as the bake read it: the file of
    :func:`resolve_source` (``given``, else the recorded path), refused unless the bytes
    decoded hash to the asset's ``source_sha256`` (a :class:`FormatError`), with every
    input policy the provenance block records — layout, input colourspace, non-finite
    repair and negative policy (``source_*`` attributes, FORMAT.md §3) — so its pixels are
    the ones the asset was computed from. ``option`` names the command's option in messages.
    """
    from shbake.envmap import load_environment

    a = asset.attrs
    path = resolve_source(a, asset_path, given, option)
    cs_in = a.get("source_colorspace_in")
    nonfinite = a.get("source_nonfinite_policy")
    env = load_environment(
        path,
        a.get("source_layout"),
        None if cs_in in (None, a.get("source_colorspace")) else cs_in,
        a.get("source_negative_policy") or "clamp",
        None if nonfinite in (None, "", "error") else nonfinite,
        quiet=True,
    )
    resources.check_digest(path, env.meta["sha256"], a.get("source_sha256", ""), "map")
    return env
