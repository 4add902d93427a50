"""The provenance block: the source map read again as the bake read it (issue 28).

A map with a NaN, negative pixels and a non-default colourspace, lat-long and as a cube
strip, baked with ``--fix-nonfinite box3 --negative keep --colorspace ACEScg``: the
preview (``--diff``), every export target and the evaluation read the map back through
:func:`shbake.format.provenance.reload_source`. Before it, ``export`` dropped the
non-finite policy and failed with "1 pixels are NaN".
"""

import json

import numpy as np
import pytest

from shbake.batch.export import options_of_target
from shbake.envmap.layouts import latlong_directions
from shbake.evaluation.env_sh import irradiance_errors
from shbake.format.asset import read_asset
from shbake.format.exports import TARGETS
from shbake.format.provenance import reload_source
from shbake.texture.cube import cube_directions
from tests.helpers import GOLDEN, write_test_exr

POLICIES = ("--fix-nonfinite", "box3", "--negative", "keep", "--colorspace", "ACEScg")
CUBES = ("--size", "16", "--floor", "8", "--samples", "16")


def _latlong_pixels():
    from shbake.envmap.image_io import read_image

    return np.asarray(read_image(str(GOLDEN / "esplanade-64x32.exr"))[0][..., :3], np.float64)


def _cube_strip_pixels(face: int = 16):
    """The golden map resampled (nearest texel) onto a cube strip: ``(6 S, S, 3)``."""
    ll = _latlong_pixels()
    h, w = ll.shape[:2]
    d = cube_directions(face).reshape(-1, 3)
    u = np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi) % 1.0  # SPEC §3
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
    px = ll[np.minimum((v * h).astype(int), h - 1), np.minimum((u * w).astype(int), w - 1)]
    return px.reshape(6 * face, face, 3)


@pytest.fixture(scope="module", params=["latlong", "cube-strip"])
def baked(request, tmp_path_factory):
    """An env_sh asset of a map with one NaN, negative pixels, ACEScg primaries."""
    folder = tmp_path_factory.mktemp(request.param)
    px = _latlong_pixels() if request.param == "latlong" else _cube_strip_pixels()
    px[3, 5, 1] = np.nan
    assert (px < 0).any()
    write_test_exr(folder / "map.exr", px)
    return folder


def test_latlong_helper_matches_spec():
    """The resampling above uses SPEC §3's lat-long addressing (cell centres map back)."""
    d = latlong_directions(4, 8)
    u = np.arctan2(d[..., 0], -d[..., 2]) / (2 * np.pi) % 1.0
    np.testing.assert_allclose(u[0], (np.arange(8) + 0.5) / 8)


def test_reloaded_map_is_the_baked_one(run_cli, baked):
    """Projecting the reloaded map gives the asset's coefficients bit for bit (the bake's own
    input, every policy applied), and its recorded counts."""
    asset_path = baked / "env.h5"
    code, _, err = run_cli("project-env", baked / "map.exr", "-o", asset_path, "--lmax", "4",
                           *POLICIES, "-q")  # fmt: skip
    assert code == 0, err
    asset = read_asset(str(asset_path))
    env = reload_source(asset, str(asset_path))
    assert env.meta["nonfinite_repaired"] == asset.attrs["source_nonfinite_repaired"] == 1
    assert env.meta["negative_count"] == asset.attrs["source_negative_count"] > 0
    assert env.layout == asset.attrs["source_layout"]
    np.testing.assert_array_equal(env.project(4), asset["/lighting/sh"])


def test_preview_export_evaluate(run_cli, baked, tmp_path):
    asset_path = baked / "env.h5"
    code, _, err = run_cli("project-env", baked / "map.exr", "-o", asset_path, "--lmax", "4",
                           "--extract-sun", *POLICIES, "-q")  # fmt: skip
    assert code == 0, err
    code, out, err = run_cli("preview", asset_path, "--diff", "--size", "16", "-o",
                             tmp_path / "pv.exr", "--json", "-q")  # fmt: skip
    assert code == 0, err
    assert json.loads(out)["relative_rms_error"] < 0.2
    for target in TARGETS:
        cubes = CUBES if "size" in options_of_target(target) else ()  # the cube-chain targets
        code, _, err = run_cli("export", asset_path, "--to", target, "--out-dir",
                               tmp_path / target, *cubes, "-q")  # fmt: skip
        assert code == 0, (target, err)
    asset = read_asset(str(asset_path))
    errors = irradiance_errors(asset, reload_source(asset, str(asset_path)))
    assert errors["irradiance"]["mean"] < 0.05, errors


@pytest.mark.parametrize("baked", ["latlong"], indirect=True)  # split-sum takes lat-long maps
def test_split_sum_probe_export(run_cli, baked, tmp_path):
    """A split-sum probe of the lat-long map (its cube chain prefiltered anew from it)."""
    code, _, err = run_cli("split-sum", baked / "map.exr", "-o", baked / "split.h5", "--size",
                           "16", "--min-size", "8", "--samples", "16", "--fix-nonfinite",
                           "box3", "--negative", "keep", "-q")  # fmt: skip
    assert code == 0, err
    code, _, err = run_cli("export", baked / "split.h5", "--to", "ktx2", "--out-dir",
                           tmp_path, *CUBES, "-q")  # fmt: skip
    assert code == 0, err
    code, _, err = run_cli("preview", baked / "split.h5", "--diff", "--size", "16",
                           "--samples", "64", "-o", tmp_path / "pv.exr", "-q")  # fmt: skip
    assert code == 0, err


class TestResolveSource:
    """A hostile asset's recorded ``source_path`` (docs/SECURITY.md §3): followed only to an
    image; a file found there is hashed, and its digest is never shown."""

    def test_not_an_image_is_never_opened(self, tmp_path, monkeypatch):
        from shbake import resources
        from shbake.errors import FormatError
        from shbake.format.provenance import resolve_source

        opened = []
        monkeypatch.setattr(resources, "sha256_of", lambda p: opened.append(p) or "")
        (tmp_path / "secret.txt").write_text("root:x:0:0")
        for recorded in ("/etc/passwd", "secret.txt", "../secret", "map.exr.txt"):
            with pytest.raises(FormatError, match="is not named as an image"):
                resolve_source({"source_path": recorded, "source_sha256": ""},
                               str(tmp_path / "a.h5"))  # fmt: skip
        assert opened == []

    def test_every_format_openimageio_reads_is_followed(self):
        """A map in any format OpenImageIO reads (BMP, PPM, WebP, …) can be found again."""
        from shbake.format.provenance import image_suffixes

        assert {".exr", ".hdr", ".bmp", ".ppm", ".webp", ".tif"} <= set(image_suffixes())
        assert ".null" not in image_suffixes() and ".txt" not in image_suffixes()

    def test_path_not_a_string(self, tmp_path):
        from shbake.errors import FormatError
        from shbake.format.provenance import resolve_source

        with pytest.raises(FormatError, match="source_path must be a string"):
            resolve_source({"source_path": ["x.exr"]}, str(tmp_path / "a.h5"))


class TestReloadSource:
    def test_other_bytes_refused_without_their_digest(self, tmp_path):
        """A map under the recorded name whose bytes are not the ones baked is refused once
        read (the check is on the bytes decoded), and the message shows no digest of it."""
        import hashlib
        from types import SimpleNamespace

        from shbake.errors import FormatError

        write_test_exr(tmp_path / "other.exr", np.ones((8, 16, 3)))
        found = hashlib.sha256((tmp_path / "other.exr").read_bytes()).hexdigest()
        asset = SimpleNamespace(attrs={"source_path": "other.exr", "source_sha256": "ab" * 32})
        with pytest.raises(FormatError, match="differs from the one recorded") as info:
            reload_source(asset, str(tmp_path / "a.h5"))
        assert found[:8] not in str(info.value)
        asset.attrs["source_sha256"] = found
        assert reload_source(asset, str(tmp_path / "a.h5")).meta["sha256"] == found
