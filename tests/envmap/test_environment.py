"""Reading a map (:func:`shbake.envmap.load_environment`): the digest it records is of the
file whose pixels it decoded."""

import hashlib

import numpy as np
import pytest

from shbake.envmap import environment, load_environment
from shbake.errors import ImageReadError
from tests.helpers import write_test_exr


class TestLoadEnvironment:
    def test_digest_and_size_are_of_the_file_read(self, tmp_path):
        path = tmp_path / "map.exr"
        write_test_exr(path, np.full((8, 16, 3), 0.5))
        meta = load_environment(str(path), quiet=True).meta
        data = path.read_bytes()
        assert meta["sha256"] == hashlib.sha256(data).hexdigest()
        assert meta["size"] == len(data)

    def test_path_like(self, tmp_path):
        """A ``pathlib.Path`` reads the map a ``str`` does (OpenImageIO takes ``str`` alone),
        and the recorded path is text."""
        path = write_test_exr(tmp_path / "map.exr", np.linspace(0.1, 2.0, 384).reshape(8, 16, 3))
        got, want = load_environment(path, quiet=True), load_environment(str(path), quiet=True)
        np.testing.assert_array_equal(got.pixels, want.pixels)
        assert got.meta["path"] == want.meta["path"] == str(path)
        assert got.meta["sha256"] == want.meta["sha256"]

    def test_file_written_during_the_read_refused(self, tmp_path, monkeypatch):
        """A map rewritten between the decode and the hash (a pipeline still writing it)
        would record the digest of bytes that were not baked: one line, nothing returned."""
        path = tmp_path / "map.exr"
        write_test_exr(path, np.full((8, 16, 3), 0.5))
        read_image = environment.read_image

        def read_then_rewrite(p):
            out = read_image(p)
            write_test_exr(path, np.full((8, 16, 3), 2.0))
            return out

        monkeypatch.setattr(environment, "read_image", read_then_rewrite)
        with pytest.raises(ImageReadError, match="changed while it was read"):
            load_environment(str(path), quiet=True)
