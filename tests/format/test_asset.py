"""The asset writer's HDF5 calls: ``write_into`` (h5py's low-level API, issue 31) makes the
file h5py's high-level API makes from the same values, byte for byte, for every kind and
for values of every type an asset may carry."""

import io

import h5py
import numpy as np
import pytest

from shbake.format import registry
from shbake.format.asset import WRITE_OPTIONS, Asset, _attr_value, file_image, root_attrs
from tests.assets_examples import example, write_map


@pytest.fixture(scope="module")
def tiny_map(tmp_path_factory):
    return write_map(tmp_path_factory.mktemp("maps") / "tiny.exr")


def high_level_image(asset: Asset) -> bytes:
    """The file image h5py's high-level API makes (the writer before issue 31): every value
    through ``attrs[k] = v`` and ``create_dataset(name, data=…, track_times=False)``."""
    name = f"high-level-{id(asset)}"
    with h5py.File(name, "w", driver="core", backing_store=False, **WRITE_OPTIONS) as f:
        root = root_attrs(asset)
        for k in sorted(root):
            f.attrs[k] = _attr_value(root[k])
        for path in sorted(asset.datasets):
            data = np.require(asset.datasets[path], requirements="C")
            ds = f.create_dataset(path, data=data, track_times=False)
            for k, v in sorted(asset.dataset_attrs.get(path, {}).items()):
                ds.attrs[k] = _attr_value(v)
        f.flush()
        return f.id.get_file_image()


def odd_asset(tiny_map) -> Asset:
    """An env_sh asset with undeclared attributes and datasets of every other type: numpy
    scalars and arrays of other dtypes, complex, bytes, object strings, a non-ASCII name,
    Fortran-ordered and strided arrays, scalar datasets, nested and reused groups."""
    a = example("env_sh", tiny_map)
    strided = np.arange(24, dtype=np.float32).reshape(4, 6)[:, ::2]
    odd = {"float32": np.float32(1.5), "uint8": np.uint8(7), "int16s": np.arange(3, dtype=np.int16),
           "bools": np.array([True, False]), "complex": 1 + 2j, "bytes": b"raw",
           "strings": np.array(["a", "bc"], dtype=h5py.string_dtype()), "naïve é": "naïve",
           "fortran": np.asfortranarray(np.ones((2, 3))), "empty": np.zeros(0),
           "big": 2**40, "json": {"b": [1, 2.5], "a": "x"}}  # fmt: skip
    datasets = dict(a.datasets) | {
        "/extra/deep/er/x": np.arange(6, dtype=np.float32).reshape(2, 3),
        "/extra/deep/y": strided,
        "/extra/s": np.float64(2.0),
        "/extra/strings": np.array(["a", "bc"], dtype=h5py.string_dtype()),
        "/top": np.arange(4, dtype=np.int8),
        "/zz/é": np.ones(2),
    }
    dattrs = dict(a.dataset_attrs) | {"/extra/deep/y": odd, "/top": {"flag": True}}
    return Asset(a.kind, a.attrs | odd, datasets, dattrs)


class TestSameBytesAsTheHighLevelApi:
    @pytest.mark.parametrize("kind", list(registry.kinds()))
    def test_every_kind(self, kind, tiny_map):
        asset = example(kind, tiny_map)
        assert file_image(asset) == high_level_image(asset)

    def test_values_of_every_type(self, tiny_map):
        asset = odd_asset(tiny_map)
        image = file_image(asset)
        assert image == high_level_image(asset)
        with h5py.File(io.BytesIO(image), "r") as f:  # a readable file of what was given
            assert f["/extra/deep/y"][()].tolist() == asset.datasets["/extra/deep/y"].tolist()
            assert f["/extra/deep/y"].attrs["naïve é"] == "naïve"


class TestLowLevelOnly:
    """Every registered kind's values take the low-level path (the high-level API is only
    for values no kind stores)."""

    @pytest.mark.parametrize("kind", list(registry.kinds()))
    def test_no_high_level_call(self, kind, tiny_map, monkeypatch):
        def refuse(*args, **kwargs):
            raise AssertionError("the high-level API was used")

        monkeypatch.setattr(h5py.AttributeManager, "create", refuse)
        monkeypatch.setattr(h5py.Group, "create_dataset", refuse)
        asset = example(kind, tiny_map)
        assert file_image(asset)[:8] == b"\x89HDF\r\n\x1a\n"
