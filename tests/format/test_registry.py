"""The asset registry: every kind round-trips, FORMAT.md matches it, readers refuse what
does not match (shapes, dtypes, finiteness, attribute types) with one line."""

import os
from pathlib import Path

import h5py
import numpy as np
import pytest

from shbake.errors import FormatError, InputError
from shbake.format import registry
from shbake.format.asset import Asset, read_asset, write_asset
from tests.assets_examples import CORRUPTIONS, corrupt, example, write_map

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def tiny_map(tmp_path_factory):
    return write_map(tmp_path_factory.mktemp("maps") / "tiny.exr")


def _equal(a, b):
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b))
    if isinstance(a, float) or isinstance(b, float):
        return a == pytest.approx(b)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    return a == b


class TestRoundTrip:
    """``write_asset`` → ``read_asset`` gives back every attribute and dataset of every kind."""

    @pytest.mark.parametrize("kind", list(registry.kinds()))
    def test_round_trip(self, kind, tiny_map, tmp_path):
        asset = example(kind, tiny_map)
        out = tmp_path / "sub" / f"{kind}.h5"
        out.parent.mkdir()
        write_asset(str(out), asset)
        back = read_asset(str(out))
        assert back.kind == kind
        assert back.attrs["format_version"] == registry.kind_of(kind).version
        assert set(back.datasets) == set(asset.datasets)
        for name, data in asset.datasets.items():
            assert back[name].dtype == np.asarray(data).dtype
            assert np.array_equal(back[name], data), name
        for k, v in asset.attrs.items():
            if k == "source_path" and v:  # stored relative to the asset
                assert v == os.path.abspath(tiny_map)
                assert back.attrs[k] == os.path.relpath(tiny_map, out.parent)
            elif k == "probe_sources":
                assert [s["source_sha256"] for s in back.attrs[k]] == [
                    s["source_sha256"] for s in v
                ]
            else:
                assert _equal(back.attrs[k], v), k

    def test_every_kind_has_an_example(self, tiny_map):
        for kind in registry.kinds():
            assert example(kind, tiny_map).kind == kind

    def test_example_table_rebuilds_its_brdf(self, tiny_map, tmp_path):
        """The example table varied an ``exponent`` Phong does not have: its BRDF could not
        be rebuilt from the asset (a usage error). Every axis is a parameter of its model."""
        from shbake.format.brdf_table import table_at

        path = tmp_path / "t.h5"
        write_asset(str(path), example("brdf_table", tiny_map))
        for at in ({}, {"n": 8.0}):
            brdf = table_at(read_asset(str(path)), at).make_brdf()
            assert brdf.name == "phong" and brdf.values["n"] == at.get("n", 2.0)

    def test_same_bytes_twice(self, tiny_map, tmp_path):
        for kind in registry.kinds():
            a, b = tmp_path / "a.h5", tmp_path / "b.h5"
            write_asset(str(a), example(kind, tiny_map))
            write_asset(str(b), example(kind, tiny_map))
            assert a.read_bytes() == b.read_bytes(), kind


class TestFormatDoc:
    """docs/FORMAT.md carries exactly the registry's MUST/MAY sections."""

    def test_in_sync(self):
        text = (ROOT / "docs" / "FORMAT.md").read_text(encoding="utf-8")
        assert registry.render_doc(text) == text, "run `make format-doc`"

    def test_every_kind_has_a_section(self):
        text = (ROOT / "docs" / "FORMAT.md").read_text(encoding="utf-8")
        for kind in registry.kinds():
            assert f"registry:{kind} begin" in text
            assert f"### Kind `{kind}`, version {registry.kind_of(kind).version}" in text

    def test_drift_is_detected(self):
        text = (ROOT / "docs" / "FORMAT.md").read_text(encoding="utf-8")
        old = "| `/lighting/sh` | ((lmax+1)**2, 3) |"
        edited = text.replace(old, "| `/lighting/sh` | (n, 3) |")
        assert edited != text
        assert registry.render_doc(edited) != edited


class TestWriteValidation:
    """Writers cannot store what readers would refuse."""

    def test_refuses_wrong_shape(self, tiny_map, tmp_path):
        asset = example("env_sh", tiny_map)
        asset.datasets["/irradiance/sh"] = np.zeros((9, 1))
        with pytest.raises(FormatError, match="irradiance/sh"):
            write_asset(str(tmp_path / "x.h5"), asset)
        assert list(tmp_path.iterdir()) == []

    def test_refuses_nan(self, tiny_map, tmp_path):
        asset = example("shexp_probe", tiny_map)
        asset.datasets["/p"] = asset.datasets["/p"].copy()
        asset.datasets["/p"][0, 0] = np.nan
        with pytest.raises(FormatError, match="non-finite"):
            write_asset(str(tmp_path / "x.h5"), asset)
        assert list(tmp_path.iterdir()) == []

    def test_refuses_unknown_kind(self, tmp_path):
        with pytest.raises(FormatError, match="unknown asset kind"):
            write_asset(str(tmp_path / "x.h5"), Asset("nope"))


class TestReadValidation:
    """``read_asset`` refuses corrupt assets with one line naming what is wrong."""

    @pytest.mark.parametrize("case", list(CORRUPTIONS))
    def test_corrupt(self, case, tiny_map, tmp_path):
        path, fragment = corrupt(case, tiny_map, tmp_path)
        with pytest.raises(FormatError) as e:
            read_asset(path)
        msg = str(e.value)
        assert "\n" not in msg and len(msg) < 400
        assert fragment in msg, msg
        assert msg.startswith(f"{path}: "), msg  # every line names the file

    @pytest.mark.parametrize("version", [2, 3])
    def test_older_version_still_read(self, version, tiny_map, tmp_path):
        """An env_sh file of version 2 (before ``/lights``) or 3 (before
        ``/lights/angular_radius``) is read as it was written."""
        path = tmp_path / "old.h5"
        write_asset(str(path), example("env_sh", tiny_map))
        now = read_asset(str(path))
        with h5py.File(path, "r+") as f:
            f.attrs["format_version"] = np.int64(version)
        back = read_asset(str(path))
        assert back.attrs["format_version"] == version
        assert registry.kind_of("env_sh").reads == (2, 3)
        assert back.datasets.keys() == now.datasets.keys()
        assert all(np.array_equal(back[k], now[k]) for k in now.datasets)

    def test_truncated(self, tiny_map, tmp_path):
        path = tmp_path / "t.h5"
        write_asset(str(path), example("env_sh", tiny_map))
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
        with pytest.raises(FormatError, match="t.h5"):
            read_asset(str(path))

    def test_exr_renamed(self, tiny_map, tmp_path):
        path = tmp_path / "map.h5"
        path.write_bytes(Path(tiny_map).read_bytes())
        with pytest.raises(FormatError, match="not a readable HDF5 asset"):
            read_asset(str(path))

    def test_unwritten_huge_extra_dataset_is_not_loaded(self, tiny_map, tmp_path):
        path = tmp_path / "bomb.h5"
        write_asset(str(path), example("env_sh", tiny_map))
        with h5py.File(path, "r+") as f:
            f.create_dataset("/extra", shape=(35000, 35000), dtype="f8")
        assert path.stat().st_size < 1 << 20
        back = read_asset(str(path))
        assert "/extra" not in back.datasets

    def test_declared_dataset_over_budget(self, tiny_map, tmp_path, monkeypatch):
        path = tmp_path / "big.h5"
        write_asset(str(path), example("env_sh", tiny_map))
        monkeypatch.setenv("SHBAKE_MAX_MEMORY", "1k")
        with pytest.raises(InputError, match="memory budget"):
            read_asset(str(path))

    def test_fifo_refused(self, tmp_path):
        fifo = tmp_path / "pipe.h5"
        os.mkfifo(fifo)
        with pytest.raises(Exception, match="FIFO"):
            read_asset(str(fifo))
