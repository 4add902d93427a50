"""Versioned, self-describing HDF5 assets (``docs/FORMAT.md``).

Writing is deterministic (no timestamps, fixed library-version bounds, sorted
attribute and group order) and atomic (:mod:`shbake.format.atomic`).
Reading refuses files that are not shbake assets, of an unknown kind, or of
a newer format version.
"""

import json
from dataclasses import dataclass, field

import h5py
import numpy as np

from shbake import __version__, conventions
from shbake.errors import FormatError
from shbake.format.atomic import atomic_path

KINDS = ("env_sh", "brdf_table", "shexp_probe", "shexp_probe_set", "splitsum_probe", "shrm")
"""Asset kinds this version of shbake reads and writes."""


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


@dataclass
class Asset:
    """An asset in memory: root attributes, and datasets (``/path`` → array) with attributes."""

    kind: str
    attrs: dict = field(default_factory=dict)
    datasets: dict = field(default_factory=dict)
    dataset_attrs: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.datasets[name]
        except KeyError:
            raise FormatError(f"asset of kind {self.kind!r} has no dataset {name}") from None

    def __contains__(self, name: str) -> bool:
        return name in self.datasets


def _attr_value(v):
    if isinstance(v, dict | list | tuple) and not isinstance(v, np.ndarray):
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


def write_asset(path: str, asset: Asset) -> None:
    """Write ``asset`` to ``path`` atomically and deterministically."""
    if asset.kind not in KINDS:
        raise FormatError(f"unknown asset kind {asset.kind!r}")
    root = {
        "format": conventions.FORMAT_NAME,
        "format_version": np.int64(conventions.FORMAT_VERSION),
        "kind": asset.kind,
        "shbake_version": __version__,
        **conventions_attrs(),
        **asset.attrs,
    }
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w", libver=("earliest", "v110"), track_order=False) as f:
            for k in sorted(root):
                f.attrs[k] = _attr_value(root[k])
            for name in sorted(asset.datasets):
                data = np.require(asset.datasets[name], requirements="C")
                ds = f.create_dataset(name, data=data, track_times=False)
                for k, v in sorted(asset.dataset_attrs.get(name, {}).items()):
                    ds.attrs[k] = _attr_value(v)


def _decode(v):
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray) and v.shape == ():
        return v.item()
    if isinstance(v, np.generic):
        return v.item()
    return v


def read_asset(path: str, kinds: tuple[str, ...] | None = None) -> Asset:
    """Read an asset, checking format name, version and kind.

    Raises
    ------
    FormatError
        Not an HDF5 file, not a shbake asset, newer version, unexpected kind.
    """
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise FormatError(f"{path}: no such file") from None
    except OSError as e:
        raise FormatError(f"{path}: not a readable HDF5 asset ({str(e).splitlines()[0]})") from None
    with f:
        attrs = {k: _decode(v) for k, v in f.attrs.items()}
        if attrs.get("format") != conventions.FORMAT_NAME:
            raise FormatError(f"{path}: not a shbake asset (no format='shbake' attribute)")
        version = attrs.get("format_version")
        if not isinstance(version, int) or version > conventions.FORMAT_VERSION or version < 1:
            raise FormatError(
                f"{path}: format_version {version!r} is not supported by shbake {__version__} "
                f"(reads 1…{conventions.FORMAT_VERSION})"
            )
        kind = attrs.get("kind")
        if kind not in KINDS or (kinds is not None and kind not in kinds):
            want = ", ".join(kinds or KINDS)
            raise FormatError(f"{path}: asset kind {kind!r} is not one of: {want}")
        datasets, dattrs = {}, {}

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                datasets["/" + name] = obj[()]
                dattrs["/" + name] = {k: _decode(v) for k, v in obj.attrs.items()}

        try:
            f.visititems(visit)
        except (OSError, RuntimeError) as e:
            raise FormatError(f"{path}: corrupt asset ({str(e).splitlines()[0]})") from None
    return Asset(kind, attrs, datasets, dattrs)
