"""Versioned, self-describing HDF5 assets (``docs/FORMAT.md``).

Writing is deterministic (no timestamps, fixed library-version bounds, sorted
attribute and group order) and atomic (:mod:`shbake.format.atomic`).
Both directions go through the per-kind registry (:mod:`shbake.format.registry`):
a writer cannot store an asset its readers would refuse, and a reader refuses
(one line) any file whose attributes or datasets do not match the declaration
before a kernel sees a value.
"""

import functools
import itertools
import os

import h5py
import numpy as np

from shbake import __version__, conventions, resources
from shbake.errors import FormatError
from shbake.format import atomic, registry
from shbake.format.atomic import atomic_path
from shbake.format.provenance import relativise


def conventions_attrs() -> dict:
    """Root attributes stating the conventions every asset uses (FORMAT.md §2)."""
    return {
        "sh_basis": conventions.BASIS,
        "sh_phase": conventions.PHASE,
        "sh_indexing": conventions.INDEXING,
        "frame": conventions.FRAME,
        "up_axis": conventions.UP_AXIS,
        "radiance_units": conventions.RADIANCE_UNITS,
    }


class Asset:
    """An asset in memory: root attributes, and datasets (``/path`` → array) with attributes.

    A plain class (a dataclass costs ~0.8 ms of code generation at import, a start-up cost
    of every command)."""

    __slots__ = ("kind", "attrs", "datasets", "dataset_attrs")

    def __init__(
        self,
        kind: str,
        attrs: dict | None = None,
        datasets: dict | None = None,
        dataset_attrs: dict | None = None,
    ):
        self.kind = kind
        self.attrs = {} if attrs is None else attrs
        self.datasets = {} if datasets is None else datasets
        self.dataset_attrs = {} if dataset_attrs is None else dataset_attrs

    def __repr__(self) -> str:
        return f"Asset({self.kind!r}, datasets={sorted(self.datasets)})"

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.datasets[name]
        except KeyError:
            raise FormatError(f"asset of kind {self.kind!r} has no dataset {name}") from None

    def __contains__(self, name: str) -> bool:
        return name in self.datasets


def _attr_value(v):
    if isinstance(v, dict | list | tuple) and not isinstance(v, np.ndarray):
        import json  # only structured attributes need it (start-up)

        return json.dumps(v, sort_keys=True, default=_json_default)
    if isinstance(v, np.ndarray):
        return v
    if isinstance(v, bool | np.bool_):
        return np.int8(v)
    return v


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o)}")


def _memory_form(v):
    """An in-memory attribute in the form the registry checks (as a reader would decode it)."""
    if isinstance(v, np.ndarray):
        return v
    if isinstance(v, tuple):
        return list(v)
    if isinstance(v, np.generic):
        return v.item()
    return v


def root_attrs(asset: Asset) -> dict:
    """Every root attribute ``write_asset`` stores for ``asset`` (in memory form)."""
    kind = registry.kind_of(asset.kind)
    return {
        "format": conventions.FORMAT_NAME,
        "format_version": kind.version,
        "kind": asset.kind,
        "shbake_version": __version__,
        **conventions_attrs(),
        **{k: _memory_form(v) for k, v in asset.attrs.items()},
    }


def validate_asset(asset: Asset, where: str = "") -> None:
    """Check an in-memory asset against its kind's registry entry (FormatError if not)."""
    kind = registry.kind_of(asset.kind)
    arrays = {k: np.asarray(v) for k, v in asset.datasets.items()}
    shapes = {k: (a.shape, a.dtype) for k, a in arrays.items()}
    dattrs = {k: {n: _memory_form(v) for n, v in d.items()}
              for k, d in asset.dataset_attrs.items()}  # fmt: skip
    _, _, selected = registry.validate(kind, root_attrs(asset), shapes, dattrs, where)
    for spec, path in selected:
        registry.check_values(spec, path, arrays[path], where)


def write_asset(path: str, asset: Asset) -> None:
    """Validate ``asset`` against the registry, then write it to ``path`` atomically and
    deterministically. ``source_path`` attributes are stored relative to ``path``'s folder."""
    asset = Asset(asset.kind, relativise(asset.attrs, path), asset.datasets, asset.dataset_attrs)
    validate_asset(asset, "refusing to write an invalid asset: ")
    nbytes = sum(np.asarray(d).nbytes for d in asset.datasets.values())
    resources.check_memory(2 * nbytes, f"writing {path}")  # the image and its copy
    image = file_image(asset)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(image)


def file_image(asset: Asset) -> bytes:
    """The bytes of ``asset``'s HDF5 file, built in memory (HDF5's ``core`` driver without
    a backing store): HDF5 never writes to disk, so a full disk or a read-only file
    system is an ordinary failed ``write`` of these bytes (one line), never an HDF5
    write error (which left h5py's objects half-closed: segfaults and ``Exception
    ignored`` tracebacks at exit). The image is byte-identical to the file HDF5 writes
    directly (tested). ``asset`` must be validated and relativised already."""
    name = f"shbake-image-{os.getpid()}-{next(_image_serial)}"  # a name, never a file
    with h5py.File(name, "w", driver="core", backing_store=False, **WRITE_OPTIONS) as f:
        write_into(f, asset)
        f.flush()
        return f.id.get_file_image()


WRITE_OPTIONS = {"libver": ("earliest", "v110"), "track_order": False}
"""The h5py file options of every asset (fixed library-version bounds, no creation order:
FORMAT.md §1)."""

_image_serial = itertools.count()
"""Distinct names for the in-memory files (HDF5 refuses a second open file of one name)."""


def write_into(f: h5py.File, asset: Asset) -> None:
    """Store ``asset``'s root attributes and datasets into the empty open file ``f``, in
    sorted order, without timestamps (deterministic bytes).

    Through h5py's low-level API: the HDF5 calls h5py's high-level API makes for
    ``f.attrs[k] = v`` and ``f.create_dataset(name, data=v, track_times=False)``, in the
    same order with the same types, spaces and property lists — so the same bytes
    (``tests/format/test_asset.py`` builds every kind both ways) — without its per-call
    work (dtype guessing, existence checks, object wrappers, new property lists): a
    strings-and-numbers asset of ~40 attributes in ~1 ms instead of ~4 ms.
    """
    root = root_attrs(asset)
    top = h5py.h5g.open(f.id, b"/")
    for k in sorted(root):
        _write_attr(top, k, _attr_value(root[k]))
    groups = {b""}  # the groups made so far, by path without the leading "/"
    for name in sorted(asset.datasets):
        data = np.require(asset.datasets[name], requirements="C")
        dataset = _create_dataset(top, name.encode("utf-8"), data, groups)
        for k, v in sorted(asset.dataset_attrs.get(name, {}).items()):
            _write_attr(dataset, k, _attr_value(v))


_STRING = h5py.string_dtype()
"""How h5py stores a Python ``str``: variable-length UTF-8."""
_DATASET_CREATE = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
_DATASET_CREATE.set_obj_track_times(False)
_DATASET_CREATE.set_attr_creation_order(0)
_GROUP_CREATE = h5py.h5p.create(h5py.h5p.GROUP_CREATE)
_GROUP_CREATE.set_obj_track_times(False)
_LINK_CREATE = h5py.h5p.create(h5py.h5p.LINK_CREATE)
_LINK_CREATE.set_create_intermediate_group(True)
_LINK_CREATE.set_char_encoding(h5py.h5t.CSET_ASCII)
"""The property lists h5py's ``create_dataset(…, track_times=False)`` and its
``require_group`` make in a file without creation order (:data:`WRITE_OPTIONS`), made once."""


def _plain(value) -> np.ndarray | None:
    """``value`` as the array h5py stores when it is a ``str`` or numbers (h5py's
    ``array_for_new_object``); ``None`` for anything else."""
    if isinstance(value, str):
        return np.array(value, dtype=_STRING)
    if isinstance(value, int | float | np.number | np.ndarray):
        data = np.asarray(value, order="C")
        if data.dtype.kind in "biufc":
            return data
    return None


@functools.lru_cache(maxsize=32)
def _types(dtype: np.dtype) -> tuple:
    """HDF5 file and memory types of ``dtype`` (h5py's ``py_create``, logical and not)."""
    return h5py.h5t.py_create(dtype, logical=True), h5py.h5t.py_create(dtype)


@functools.lru_cache(maxsize=32)
def _space(shape: tuple):
    """A simple HDF5 dataspace of ``shape`` (``()``: scalar)."""
    return h5py.h5s.create_simple(shape)


def _write_attr(loc, name: str, value) -> None:
    """``loc.attrs[name] = value`` (``loc``: a low-level group or dataset without that
    attribute); values other than strings and numbers through h5py's high-level API."""
    data = _plain(value)
    if data is None:
        high = h5py.Group(loc) if isinstance(loc, h5py.h5g.GroupID) else h5py.Dataset(loc)
        high.attrs.create(name, data=value)
        return
    file_type, memory_type = _types(data.dtype)
    attr = h5py.h5a.create(loc, name.encode("utf-8"), file_type, _space(data.shape))
    try:
        attr.write(data, mtype=memory_type)
    finally:
        attr.close()


def _create_dataset(top, name: bytes, data: np.ndarray, groups: set):
    """The dataset ``name`` holding ``data`` under the root group ``top``, made as h5py's
    ``create_dataset(name, data=data, track_times=False)`` makes it: its parent group first
    when missing (``require_group``, intermediate groups included, added to ``groups``),
    then the dataset, contiguous, written whole; data other than numbers through h5py's
    high-level API."""
    loc = top
    if b"/" in name.lstrip(b"/"):
        parent, name = name.rsplit(b"/", 1)
        path = parent.strip(b"/")
        if path in groups:
            loc = h5py.h5g.open(top, parent)
        else:
            loc = h5py.h5g.create(top, parent, lcpl=_LINK_CREATE, gcpl=_GROUP_CREATE)
            parts = path.split(b"/")
            groups.update(b"/".join(parts[: i + 1]) for i in range(len(parts)))
    stored = _plain(data)
    if stored is None:
        return h5py.Group(loc).create_dataset(name, data=data, track_times=False).id
    dataset = h5py.h5d.create(loc, name, _types(stored.dtype)[0], _space(stored.shape),
                              dcpl=_DATASET_CREATE)  # fmt: skip
    dataset.write(h5py.h5s.ALL, h5py.h5s.ALL, stored)
    return dataset


HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
"""The first bytes of an HDF5 file without a user block (every file shbake writes)."""


def is_asset_file(path: str) -> bool:
    """Whether the regular file ``path`` starts with :data:`HDF5_SIGNATURE` (an asset to
    read), not an image (a map to bake); refuses a folder, FIFO or device first."""
    resources.check_regular_file(path, "input")
    with open(path, "rb") as f:
        return f.read(len(HDF5_SIGNATURE)) == HDF5_SIGNATURE


def _open(path: str):
    resources.check_regular_file(path, "asset")
    try:  # sec2 named: HDF5_DRIVER cannot choose a driver that reads other files
        return h5py.File(path, "r", driver="sec2")
    except OSError as e:
        raise FormatError(f"{path}: not a readable HDF5 asset ({_first_line(e)})") from None


LINKS_MAX = 4096
"""Most links an asset may hold (the largest kinds hold a few dozen)."""

PLAIN_LAYOUTS = (h5py.h5d.CONTIGUOUS, h5py.h5d.COMPACT)
"""Dataset storage a reader accepts: bytes inside the file, unfiltered (shbake writes
contiguous datasets; compact ones are the same bytes in the object header)."""


def check_self_contained(f: h5py.File, where: str = "") -> None:
    """Refuse (:class:`FormatError`, one line naming the link or dataset) a file that is not
    plain and self-contained, before any dataset value is read.

    Every link must be a hard link (soft links, dangling or not, external links to other
    files and user-defined links are refused), and every dataset stored contiguous or
    compact in the file: virtual datasets (bytes from other datasets or files), external
    storage (``H5Pset_external``: bytes from any file, ``/etc/passwd`` included, resolved
    with ``HDF5_EXTFILE_PREFIX``) and chunked storage (filters — compression, plugins
    loaded from ``HDF5_PLUGIN_PATH`` — and chunk buffers sized by the file) are refused.
    The checks read link and storage metadata only: neither other files nor plugins are
    opened. More than :data:`LINKS_MAX` links are refused.
    """
    links = []

    def collect(name, info):
        links.append((name, info.type))
        return True if len(links) > LINKS_MAX else None  # non-None stops the visit

    f.id.links.visit(collect, info=True)
    if len(links) > LINKS_MAX:
        raise FormatError(f"{where}more than {LINKS_MAX} links (not a shbake asset)")
    for raw, link_type in links:
        name = _shown("/" + raw.decode("utf-8", "replace"))
        if link_type == h5py.h5l.TYPE_EXTERNAL:
            reason = f"link {name} is an external link to another file"
        elif link_type == h5py.h5l.TYPE_SOFT:
            reason = f"link {name} is a soft link"
        elif link_type != h5py.h5l.TYPE_HARD:
            reason = f"link {name} is a user-defined link (type {link_type})"
        elif h5py.h5o.get_info(f.id, raw).type != h5py.h5o.TYPE_DATASET:
            continue
        else:
            problem = _storage_problem(h5py.h5d.open(f.id, raw).get_create_plist())
            if problem is None:
                continue
            reason = f"dataset {name} {problem}"
        raise FormatError(f"{where}{reason}; shbake reads self-contained HDF5 files "
                          "only (hard links, contiguous datasets)")  # fmt: skip


def _storage_problem(dcpl) -> str | None:
    """Why a dataset's storage (its creation property list) is not plain, or ``None``."""
    layout = dcpl.get_layout()
    if layout == h5py.h5d.VIRTUAL:
        return "is a virtual dataset (its bytes come from other datasets or files)"
    if dcpl.get_external_count():
        target = dcpl.get_external(0)[0].decode("utf-8", "replace")
        return f"keeps its bytes in the external file {registry.short(target)}"
    if dcpl.get_nfilters():
        code, _, _, label = dcpl.get_filter(0)
        return (f"is stored through the filter {registry.short(label.decode('utf-8', 'replace'))}"
                f" (id {code})")  # fmt: skip
    if layout not in PLAIN_LAYOUTS:
        return "has chunked storage"
    return None


def _shown(name: str) -> str:
    """A name from a file as a message shows it: as is if short and printable."""
    return name if name.isprintable() and len(name) <= 120 else registry.short(name, 120)


def _first_line(e) -> str:
    lines = str(e).strip().splitlines()
    return registry.short(lines[0], 120).strip("'\"") if lines else type(e).__name__


def read_asset(path: str, kinds: tuple[str, ...] | None = None,
               datasets: tuple[str, ...] | None = None) -> Asset:  # fmt: skip
    """Read and validate an asset.

    Format name, version and kind are checked first; then every declared attribute's
    type and every declared dataset's shape and dtype from the HDF5 metadata; only
    then are the declared datasets loaded (``datasets``: only those paths, and
    families by prefix), each checked for finiteness. Undeclared datasets are never
    read. The bytes to load are checked against the memory budget.

    Raises
    ------
    FormatError
        Not an HDF5 file, not self-contained (:func:`check_self_contained`), not a
        shbake asset, unknown kind or version, or any attribute or dataset that does
        not match the registry (one line).
    """
    where = f"{path}: "
    f = _open(atomic.staged(path) or path)  # an output this run wrote reads from its temporary
    try:
        with f:
            check_self_contained(f, where)
            raw = {}
            for k in f.attrs:
                try:
                    raw[k] = registry.decode_attr(f.attrs[k])
                except (OSError, TypeError, ValueError) as e:
                    msg = f"{where}unreadable attribute {k} ({_first_line(e)})"
                    raise FormatError(msg) from None
            fmt = raw.get("format")
            if not (isinstance(fmt, str) and fmt == conventions.FORMAT_NAME):
                raise FormatError(f"{where}not a shbake asset (format attribute is "
                                  f"{registry.short(fmt)}, expected 'shbake')")  # fmt: skip
            kind_name = raw.get("kind")
            if not isinstance(kind_name, str) or kind_name not in registry.kinds():
                raise FormatError(
                    f"{where}asset kind {registry.short(kind_name)} is unknown to "
                    f"shbake {__version__} (knows: {', '.join(registry.kinds())})"
                )
            if kinds is not None and kind_name not in kinds:
                raise FormatError(f"{where}asset kind {kind_name!r} is not one of: "
                                  f"{', '.join(kinds)}")  # fmt: skip
            kind = registry.kind_of(kind_name)
            version = raw.get("format_version")
            readable = (kind.version, *kind.reads)
            if isinstance(version, bool) or not isinstance(version, int) or version not in readable:
                raise FormatError(
                    f"{where}format_version {registry.short(version)} of kind {kind_name} is not "
                    f"supported by shbake {__version__} (reads version "
                    f"{', '.join(map(str, sorted(readable)))})"
                )
            shapes, groups = {}, set()

            def visit(name, obj):
                if isinstance(obj, h5py.Dataset):
                    shapes["/" + name] = (obj.shape, obj.dtype)
                else:
                    groups.add("/" + name)

            try:
                f.visititems(visit)
                for spec in kind.datasets:  # a group where a dataset belongs is not "absent"
                    if spec.path in groups:
                        raise FormatError(f"{where}{spec.path} is a group, not a dataset")
                attrs, dattrs_ok, selected = registry.validate(
                    kind, raw, shapes, _LazyAttrs(f, where), where
                )
            except (OSError, RuntimeError, KeyError) as e:
                raise FormatError(f"{where}corrupt asset ({_first_line(e)})") from None
            if datasets is not None:
                selected = [
                    (s, p)
                    for s, p in selected
                    if any(p == d or p.startswith(d.rstrip("/") + "/") for d in datasets)
                ]
            nbytes = sum(int(np.prod(shapes[p][0], dtype=np.float64)) * shapes[p][1].itemsize
                         for _, p in selected)  # fmt: skip
            resources.check_memory(2 * nbytes, f"reading {path}")
            loaded = {}
            for spec, p in selected:
                try:
                    data = f[p][()]
                except (OSError, RuntimeError, ValueError) as e:
                    raise FormatError(f"{where}corrupt dataset {p} ({_first_line(e)})") from None
                registry.check_values(spec, p, np.asarray(data), where)
                loaded[p] = data
            return Asset(kind_name, attrs, loaded, {p: dattrs_ok[p] for _, p in selected})
    except (OSError, RuntimeError) as e:
        raise FormatError(f"{where}corrupt asset ({_first_line(e)})") from None


class _LazyAttrs:
    """``path → decoded attributes`` of a file's datasets, read on demand."""

    def __init__(self, f, where):
        self.f, self.where = f, where

    def get(self, path, default=None):
        if path not in self.f:
            return default
        out = {}
        for k in self.f[path].attrs:
            try:
                out[k] = registry.decode_attr(self.f[path].attrs[k])
            except (OSError, TypeError, ValueError) as e:
                raise FormatError(f"{self.where}unreadable attribute {k} of {path} "
                                  f"({_first_line(e)})") from None  # fmt: skip
        return out
