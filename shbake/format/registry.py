"""The asset registry: for every kind, its format version, attributes and datasets.

One declaration per kind (:func:`register`) says what an asset of that kind
MUST and MAY hold: root attributes with their types and ranges, datasets with
shape patterns, dtypes and finiteness, and the dataset attributes readers rely
on. :func:`shbake.format.asset.write_asset` validates an asset against it
before writing; :func:`shbake.format.asset.read_asset` validates a file
against it from the HDF5 metadata *before* loading anything, loads only the
declared datasets, and checks their values' finiteness. ``docs/FORMAT.md``
carries one MUST/MAY section per kind rendered by :func:`markdown`
(``tests/format/test_registry.py`` fails when they drift).

Shape patterns
--------------
A dataset's ``shape`` is a tuple of dimensions, each one of

- an ``int``: that exact size;
- an identifier (``"H"``): a symbol, bound by its first use and equal at every
  later use (root and dataset attributes marked ``symbol=`` bind symbols too);
- an expression over bound symbols (``"(lmax+1)**2"``);
- ``"*name"`` (first dimension only): any number of leading dimensions, bound
  as a tuple; the kind's ``check`` function says what they must be.

Families (``/levels/{k}``) are expanded by the kind's ``members(spec, attrs, dattrs)``;
each member is checked in its own copy of the symbol table.

Adding a kind
-------------
One ``register(Kind(...))`` in the kind's module under ``shbake/format/`` (its builder and
typed reader live there too), that module's name in :data:`KIND_MODULES`, one example in
``tests/assets_examples.py`` (``tests/format/test_registry.py`` fails for a kind without one),
then ``make format-doc`` writes its FORMAT.md section.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from shbake import conventions
from shbake.errors import FormatError

ATTR_TYPES = ("str", "int", "float", "bool", "json", "floats")
"""Attribute types: ``floats`` is a 1-D float array; ``json`` a JSON text (structured value)."""

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z_0-9]*$")


class Attr(NamedTuple):
    """One attribute: name, type (:data:`ATTR_TYPES`), meaning, whether it MUST be present.

    ``range``: inclusive ``(lo, hi)`` for ``int``/``float``; ``length``: required
    length of a ``floats`` array or a ``json`` list; ``json_type``: ``list`` or
    ``dict`` for ``json``; ``symbol``: an ``int`` attribute that binds a shape symbol.
    """

    name: str
    type: str
    doc: str
    required: bool = True
    range: tuple | None = None
    length: int | str | None = None
    json_type: type | None = None
    symbol: str | None = None


class Data(NamedTuple):
    """One dataset (or family ``/name/{k}``): shape pattern, dtype, meaning.

    ``with_``: MUST be present when that other dataset is (and MAY otherwise).
    ``finite``: every value MUST be finite. ``values``: a further check of the loaded
    array (raises :class:`FormatError`).
    """

    path: str
    shape: tuple
    dtype: str
    doc: str
    required: bool = True
    finite: bool = True
    attrs: tuple = ()
    with_: str | None = None
    values: Callable | None = None


class Kind(NamedTuple):
    """A registered asset kind."""

    name: str
    version: int
    title: str
    attrs: tuple
    datasets: tuple
    notes: tuple = ()
    provenance: bool = True
    members: Callable | None = None
    check: Callable | None = None
    doc: str = ""
    reads: tuple[int, ...] = ()
    """Earlier format versions readers still accept: their files are valid files of this
    version (the newer version only added optional members)."""

    def dataset(self, path: str) -> Data:
        for d in self.datasets:
            if d.path == path:
                return d
        raise KeyError(path)


KINDS: dict[str, Kind] = {}
"""Every registered kind, by name, in registration order."""


def register(kind: Kind) -> Kind:
    """Add ``kind`` to :data:`KINDS` (one call per kind; see the kind modules)."""
    for a in kind.attrs:
        if a.type not in ATTR_TYPES:
            raise ValueError(f"{kind.name}: attribute {a.name} has unknown type {a.type!r}")
    KINDS[kind.name] = kind
    return kind


def kind_of(name) -> Kind:
    """The registered :class:`Kind` called ``name``; :class:`FormatError` if there is none."""
    module = f"shbake.format.{name}" if isinstance(name, str) else None
    if name not in KINDS and module in KIND_MODULES:  # just the one kind's module (start-up)
        import importlib

        importlib.import_module(module)
    if name not in KINDS:
        _load_kinds()
    if not isinstance(name, str) or name not in KINDS:
        raise FormatError(f"unknown asset kind {short(name)}; known: {', '.join(KINDS)}")
    return KINDS[name]


KIND_MODULES = (
    "shbake.format.env_sh",
    "shbake.format.brdf_table",
    "shbake.format.shexp",
    "shbake.format.splitsum",
    "shbake.format.shrm",
)
"""Modules whose import registers kinds: a new kind is one :func:`register` call in its
module, and that module's name here."""


def _load_kinds() -> None:
    """Import the modules that register the kinds (they import this module)."""
    import importlib

    for name in KIND_MODULES:
        importlib.import_module(name)


# -- attributes shared by every kind -------------------------------------------------------

ROOT_ATTRS = (
    Attr("format", "str", 'MUST be `"shbake"`'),
    Attr("format_version", "int", "the kind's format version (below)", range=(1, 1 << 30)),
    Attr("kind", "str", "asset kind (one of the sections below)"),
    Attr("shbake_version", "str", "writer version"),
    Attr("sh_basis", "str", f'`"{conventions.BASIS}"`'),
    Attr("sh_phase", "str", f'`"{conventions.PHASE}"`'),
    Attr("sh_indexing", "str", f'`"{conventions.INDEXING}"`'),
    Attr("frame", "str", f'`"{conventions.FRAME}"`'),
    Attr("up_axis", "str", f'`"{conventions.UP_AXIS}"`'),
    Attr("radiance_units", "str", conventions.RADIANCE_UNITS),
)

PROVENANCE_ATTRS = (
    Attr("source_path", "str", "the input file, relative to the asset's folder where possible "
         '(absolute otherwise); `""` when the asset has no input file'),
    Attr("source_sha256", "str", 'hex SHA-256 of the input\'s bytes (`""` without input)'),
    Attr("source_size", "int", "bytes of the input file (0 without input)", range=(0, 1 << 62)),
    Attr("source_nonfinite_policy", "str", 'NaN/Inf pixels: `error`, `black`, `box3` '
         '(`""` when the input is not a map)'),
    Attr("source_negative_policy", "str", 'negative pixels: `clamp`, `keep`, `error` '
         '(`""` when the input is not a map)'),
    Attr("command_line", "str", "the command that wrote the asset. Writers of probe kinds MUST "
         "NOT record it (a probe is a pure function of its map and configuration, byte-identical "
         "from any runner)", required=False),
)  # fmt: skip
"""The provenance block every kind carries (``provenance=True``)."""

SOURCE_MAP_ATTRS = (
    Attr("source_width", "int", "pixels", range=(1, 1 << 31)),
    Attr("source_height", "int", "pixels", range=(1, 1 << 31)),
    Attr("source_layout", "str", "`latlong`, `cube-strip`, `cross-h` or `cross-v`"),
    Attr("source_colorspace", "str", "working space the pixels were converted to"),
    Attr("source_colorspace_in", "str", "the input's declared colour space", required=False),
    Attr("probe_position", "floats", "a scene probe's world position `[x, y, z]` (scene units; "
         "recorded, not used by the bake)", required=False, length=3),
    Attr("probe_rotation_deg", "float", "a scene probe's turn of its environment about +Y, "
         "degrees counter-clockwise seen from above: direction `R d` of the asset shows the "
         "map's `d` (`shbake.envmap.turn`)", required=False),
)
"""Extra provenance of kinds baked from an environment map."""

AXES_ATTR = Attr("axes", "json", "axis names", json_type=list, required=False)
"""A dataset's axis names, slowest first."""
MEANING_ATTR = Attr("meaning", "str", "what the values are, in words", required=False)
"""A dataset's meaning in words (for a person reading the file)."""

MAP_POLICY_ATTRS = (
    Attr("source_stored_format", "str", "pixel type stored in the input file"),
    Attr("source_channels", "str", "how the input's channels became RGB"),
    Attr("source_nonfinite_repaired", "int", "pixels repaired by the non-finite policy",
         range=(0, 1 << 62)),
    Attr("source_negative_count", "int", "negative pixels found", range=(0, 1 << 62)),
    Attr("source_negative_energy_change", "floats", "change of `∫L dω` per channel by the "
         "negative policy", length=3),
)  # fmt: skip
"""What the input policies found in the map (:func:`shbake.format.provenance.map_source`
writes them for every kind baked from a map; ``env_sh`` MUST hold them, the other kinds
MAY: :func:`optional`)."""


def optional(attrs: tuple) -> tuple:
    """``attrs`` declared MAY (``required=False``)."""
    return tuple(a._replace(required=False) for a in attrs)


MAP_KIND_ATTRS = SOURCE_MAP_ATTRS + optional(MAP_POLICY_ATTRS)
"""The map provenance of the kinds baked from a map other than ``env_sh`` (probes, SHRM)."""


def attrs_of(kind: Kind) -> tuple:
    """Every root attribute of ``kind``: common, provenance, then its own."""
    return ROOT_ATTRS + (PROVENANCE_ATTRS if kind.provenance else ()) + kind.attrs


# -- validation ------------------------------------------------------------------------------


def short(v, limit: int = 60) -> str:
    """A one-line, bounded ``repr`` of a value (arrays by shape and dtype)."""
    if isinstance(v, np.ndarray):
        return f"an array of shape {v.shape} and dtype {v.dtype}"
    text = repr(v).replace("\n", " ")
    return text if len(text) <= limit else text[: limit - 1] + "…"


def decode_attr(raw):
    """An attribute as stored by h5py → a Python value (bytes → str, 0-d → scalar)."""
    if isinstance(raw, bytes):
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            return raw
    if isinstance(raw, np.ndarray) and raw.shape == ():
        return decode_attr(raw[()])
    if isinstance(raw, np.bytes_):
        return decode_attr(bytes(raw))
    if isinstance(raw, np.generic):
        return raw.item() if not isinstance(raw, np.str_) else str(raw)
    return raw


def check_attr(spec: Attr, value, where: str, symbols: dict | None = None):
    """Validate one decoded attribute value; return it in its in-memory form.

    ``json`` attributes come back parsed; ``bool`` as ``bool``; ``floats`` as a
    float64 array. Raises :class:`FormatError` naming ``where`` and the attribute.
    """
    name = f"{where}attribute {spec.name}"
    t = spec.type
    if t == "str":
        if not isinstance(value, str):
            raise FormatError(f"{name} must be a string, found {short(value)}")
        return value
    if t == "json":
        if isinstance(value, str):
            import json  # only assets with structured attributes need it (start-up)

            try:
                value = json.loads(value)
            except ValueError:
                raise FormatError(f"{name} is not valid JSON: {short(value)}") from None
        elif not isinstance(value, list | dict):
            raise FormatError(f"{name} must be JSON text, found {short(value)}")
        if spec.json_type is not None and not isinstance(value, spec.json_type):
            raise FormatError(f"{name} must be a JSON {spec.json_type.__name__}, found "
                              f"{type(value).__name__}")  # fmt: skip
        _check_length(spec, value, name, symbols)
        return value
    if t == "floats":
        if isinstance(value, list | tuple):
            value = np.asarray(value)
        if not (isinstance(value, np.ndarray) and value.ndim == 1 and value.dtype.kind in "fiu"):
            raise FormatError(f"{name} must be a 1-D array of numbers, found {short(value)}")
        value = value.astype(np.float64)
        if not np.all(np.isfinite(value)):
            raise FormatError(f"{name} holds non-finite values")
        _check_length(spec, value, name, symbols)
        return value
    if t == "bool":
        if isinstance(value, bool | np.bool_):
            return bool(value)
        if isinstance(value, int | np.integer) and int(value) in (0, 1):
            return bool(value)
        raise FormatError(f"{name} must be a boolean (int8 0 or 1), found {short(value)}")
    if t == "int":
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
            raise FormatError(f"{name} must be an integer, found {short(value)}")
        value = int(value)
    elif t == "float":
        if isinstance(value, bool | np.bool_) or not isinstance(
            value, int | float | np.integer | np.floating
        ):
            raise FormatError(f"{name} must be a number, found {short(value)}")
        value = float(value)
        if not math.isfinite(value):
            raise FormatError(f"{name} is not finite ({value})")
    if spec.range is not None:
        lo, hi = spec.range
        if not lo <= value <= hi:
            raise FormatError(f"{name} = {value} is outside [{lo}, {hi}]")
    if spec.symbol and symbols is not None:
        bind(symbols, spec.symbol, value, name)
    return value


def _check_length(spec, value, name, symbols):
    if spec.length is None:
        return
    want = spec.length if isinstance(spec.length, int) else (symbols or {}).get(spec.length)
    if want is not None and len(value) != want:
        raise FormatError(f"{name} must have {want} entries, found {len(value)}")


def bind(symbols: dict, name: str, value, where: str) -> None:
    """Bind shape symbol ``name`` or check it equals its earlier binding."""
    if name in symbols and symbols[name] != value:
        raise FormatError(f"{where}: {name} = {value} disagrees with {name} = {symbols[name]}")
    symbols[name] = value


def check_shape(spec: Data, path: str, shape: tuple, dtype, symbols: dict, where: str) -> None:
    """Check a dataset's shape and dtype against its pattern (binding symbols)."""
    name = f"{where}dataset {path}"
    if np.dtype(dtype) != np.dtype(spec.dtype):
        raise FormatError(f"{name} must be {spec.dtype}, found {np.dtype(dtype)}")
    pattern = list(spec.shape)
    shape = tuple(int(s) for s in shape)
    if pattern and isinstance(pattern[0], str) and pattern[0].startswith("*"):
        lead = len(shape) - (len(pattern) - 1)
        if lead < 0:
            raise FormatError(f"{name} must have at least {len(pattern) - 1} dimensions, "
                              f"found shape {shape}")  # fmt: skip
        bind(symbols, pattern[0][1:], shape[:lead], name)
        pattern, shape = pattern[1:], shape[lead:]
    elif len(shape) != len(pattern):
        raise FormatError(f"{name} must have shape {pattern_text(spec.shape)}, found {shape}")
    for dim, n in zip(pattern, shape, strict=True):
        if isinstance(dim, int):
            want = dim
        elif _IDENT.match(dim):
            if dim not in symbols:
                if n < 1:
                    raise FormatError(f"{name} has an empty dimension {dim} (shape {shape})")
                symbols[dim] = n
                continue
            want = symbols[dim]
        else:
            want = eval(dim, {"__builtins__": {}}, dict(symbols))  # noqa: S307 (our own patterns)
        if n != want:
            raise FormatError(
                f"{name} must have shape {pattern_text(spec.shape, symbols)}, found {shape}"
            )


def pattern_text(shape: tuple, symbols: dict | None = None) -> str:
    """``(n, 3)``-style text of a shape pattern, with known symbols substituted."""
    out = []
    for d in shape:
        if isinstance(d, str) and symbols:
            if d.startswith("*"):
                v = symbols.get(d[1:])
                out.append(", ".join(map(str, v)) if v is not None else d)
                continue
            try:
                d = eval(d, {"__builtins__": {}}, dict(symbols))  # noqa: S307
            except NameError:
                pass
        out.append(str(d))
    return "(" + ", ".join(out) + (",)" if len(out) == 1 else ")")


def expand(kind: Kind, attrs: dict, present, dattrs=None) -> list[tuple[Data, str]]:
    """``(spec, path)`` of every declared dataset the asset has or MUST have.

    ``present(path)`` says whether the asset holds ``path``. Raises
    :class:`FormatError` for a missing required dataset.
    """
    out = []
    for spec in kind.datasets:
        if "{" in spec.path:
            for path in kind.members(spec, attrs, dattrs or {}):
                if present(path):
                    out.append((spec, path))
                elif spec.required:
                    raise FormatError(f"missing dataset {path} (required in a {kind.name} asset)")
            continue
        if present(spec.path):
            out.append((spec, spec.path))
        elif spec.required or (spec.with_ is not None and present(spec.with_)):
            raise FormatError(f"missing dataset {spec.path} (required in a {kind.name} asset)")
    return out


def validate(kind: Kind, attrs: dict, shapes: dict, dattrs: dict, where: str = "") -> tuple:
    """Check attributes and dataset metadata of an asset of ``kind``.

    ``attrs``: decoded root attributes; ``shapes``: ``path → (shape, dtype)`` of
    every dataset present; ``dattrs``: ``path → decoded attributes``. Returns
    ``(attrs, dattrs, selected)``: attributes in their in-memory form and the
    ``(spec, path)`` of the declared datasets (the only ones a reader loads).
    """
    symbols: dict = {}
    out_attrs = dict(attrs)
    for spec in attrs_of(kind):
        if spec.name not in attrs:
            if spec.required:
                raise FormatError(f"{where}missing attribute {spec.name} "
                                  f"(required in a {kind.name} asset)")  # fmt: skip
            continue
        out_attrs[spec.name] = check_attr(spec, attrs[spec.name], where, symbols)
    try:
        selected = expand(kind, out_attrs, lambda p: p in shapes, dattrs)
    except FormatError as e:
        raise FormatError(f"{where}{e}") from None
    out_dattrs = {}
    for spec, path in selected:
        local = dict(symbols) if "{" in spec.path else symbols
        da = dict(dattrs.get(path, {}))
        for a in spec.attrs:
            if a.name not in da:
                if a.required:
                    raise FormatError(f"{where}dataset {path} misses attribute {a.name}")
                continue
            da[a.name] = check_attr(a, da[a.name], f"{where}dataset {path} ", local)
        shape, dtype = shapes[path]
        check_shape(spec, path, shape, dtype, local, where)
        out_dattrs[path] = da
    if kind.check is not None:
        try:
            kind.check(out_attrs, {p: shapes[p][0] for _, p in selected}, out_dattrs, symbols)
        except FormatError as e:
            raise FormatError(f"{where}{e}") from None
    return out_attrs, out_dattrs, selected


def check_values(spec: Data, path: str, data: np.ndarray, where: str = "") -> None:
    """Finiteness of a loaded dataset (when its spec asks for it)."""
    if spec.finite and data.dtype.kind == "f" and not np.all(np.isfinite(data)):
        bad = int(np.size(data) - np.count_nonzero(np.isfinite(data)))
        raise FormatError(f"{where}dataset {path} holds {bad} non-finite values")
    if spec.values is not None:
        try:
            spec.values(data)
        except FormatError as e:
            raise FormatError(f"{where}{e}") from None


# -- documentation -------------------------------------------------------------------------

_TYPE_TEXT = {"str": "str", "int": "int", "float": "float", "bool": "int8 0/1",
              "json": "JSON text", "floats": "float64 array"}  # fmt: skip


def _attr_rows(attrs) -> list[str]:
    rows = ["| attribute | type | MUST/MAY | meaning |", "|---|---|---|---|"]
    for a in attrs:
        t = _TYPE_TEXT[a.type]
        if a.json_type is not None:
            t += f" ({a.json_type.__name__})"
        if a.length is not None:
            t += f", length {a.length}"
        if a.range is not None:
            t += f", [{a.range[0]}, {a.range[1]}]"
        rows.append(f"| `{a.name}` | {t} | {'MUST' if a.required else 'MAY'} | {a.doc} |")
    return rows


def markdown(kind: Kind) -> str:
    """The MUST/MAY section of ``kind`` as it appears in ``docs/FORMAT.md``."""
    lines = [f"<!-- registry:{kind.name} begin (generated by shbake.format.registry; "
             "edit the declaration, then `make format-doc`) -->",
             f"### Kind `{kind.name}`, version {kind.version}{_also_reads(kind)}: {kind.title}",
             ""]  # fmt: skip
    if kind.doc:
        lines += [kind.doc, ""]
    lines += ["Root attributes (besides §2" + (" with the provenance block" if kind.provenance
              else "") + "):", ""]  # fmt: skip
    lines += _attr_rows(kind.attrs) if kind.attrs else ["(none)"]
    lines += ["", "| dataset | shape | dtype | MUST/MAY | finite | meaning |",
              "|---|---|---|---|---|---|"]  # fmt: skip
    for d in kind.datasets:
        need = "MUST" if d.required else (f"with `{d.with_}`" if d.with_ else "MAY")
        lines.append(
            f"| `{d.path}` | {pattern_text(d.shape)} | {d.dtype} | {need} | "
            f"{'MUST' if d.finite else '—'} | {d.doc} |"
        )
    for d in kind.datasets:
        if d.attrs:
            lines += ["", f"Attributes of `{d.path}`:", ""] + _attr_rows(d.attrs)
    if kind.notes:
        lines.append("")
        lines += [f"- {n}" for n in kind.notes]
    lines.append(f"<!-- registry:{kind.name} end -->")
    return "\n".join(lines)


def markdown_common() -> str:
    """The §2/§3 tables: root attributes and the provenance block."""
    return "\n".join(
        ["<!-- registry:common begin -->", "Root attributes of every kind:", ""]
        + _attr_rows(ROOT_ATTRS)
        + ["", "Provenance block (every kind):", ""]
        + _attr_rows(PROVENANCE_ATTRS)
        + ["", "Kinds baked from an environment map add:", ""]
        + _attr_rows(SOURCE_MAP_ATTRS)
        + ["<!-- registry:common end -->"]
    )


def kinds() -> dict[str, Kind]:
    """All registered kinds (imports the kind declarations)."""
    _load_kinds()
    return KINDS


def _also_reads(kind: Kind) -> str:
    """`` (readers also accept version 2)`` for a kind that still reads older versions."""
    if not kind.reads:
        return ""
    return f" (readers also accept version {', '.join(map(str, kind.reads))})"


def render_doc(text: str) -> str:
    """``docs/FORMAT.md`` text with every generated block replaced by the registry's.

    Blocks are delimited by ``<!-- registry:NAME begin … -->`` and ``<!-- registry:NAME end
    -->``; a kind without a block is appended before the ``Companion files`` section.
    """
    blocks = {"common": markdown_common()} | {k.name: markdown(k) for k in kinds().values()}
    for name, block in blocks.items():
        pat = re.compile(
            rf"<!-- registry:{re.escape(name)} begin.*?<!-- registry:{re.escape(name)} end -->",
            re.S,
        )
        if pat.search(text):
            text = pat.sub(lambda m, b=block: b, text)
        else:
            i = text.find("\n## Companion files")
            i = len(text) if i < 0 else i
            text = text[:i] + "\n" + block + "\n" + text[i:]
    return text


def main(argv=None) -> int:
    """``python -m shbake.format.registry [docs/FORMAT.md]``: regenerate the blocks in place."""
    import sys

    from shbake.format import registry  # not __main__: the kinds register there

    path = (argv or sys.argv[1:] or ["docs/FORMAT.md"])[0]
    with open(path, encoding="utf-8") as f:
        text = f.read()
    new = registry.render_doc(text)
    if new != text:
        with open(path, "w", encoding="utf-8") as f:
            f.write(new)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
