"""Corrupt assets (issue 11, items 6 and 7; issue 10): every corruption is one line and exit 1
in every command that reads assets.
"""

import pytest

from tests.assets_examples import CORRUPTIONS, corrupt
from tests.faults import PREVIEW_OF_KIND, assert_failed, unchanged


class TestCorruptAssets:
    """Items 6 and 7, issue 10: every corrupt asset is one line and exit 1 in every command
    that reads assets (preview of each kind; preview --table for tables)."""

    @pytest.mark.parametrize("case", list(CORRUPTIONS))
    def test_preview(self, run_cli, ws, tmp_path, case):
        path, fragment = corrupt(case, ws / "map.exr", tmp_path)
        kind = CORRUPTIONS[case][0]
        out = tmp_path / "p.exr"
        if kind == "brdf_table":
            args = ["preview", ws / "env_sh.h5", "--pass", "kautz", "--table", path, "-o", out,
                    "--size", 8]  # fmt: skip
        else:
            args = PREVIEW_OF_KIND[kind](path, out)
        with unchanged(tmp_path):
            assert_failed(run_cli(*args), fragment=fragment)

    @pytest.mark.parametrize("case", [c for c, v in CORRUPTIONS.items() if v[0] == "env_sh"])
    def test_export(self, run_cli, ws, tmp_path, case):
        path, fragment = corrupt(case, ws / "map.exr", tmp_path)
        with unchanged(tmp_path):
            assert_failed(run_cli("export", path, "--to", "threejs", "-o", tmp_path / "x.json"),
                          fragment=fragment)  # fmt: skip

    def test_truncated(self, run_cli, ws, tmp_path):
        data = (ws / "env_sh.h5").read_bytes()
        (tmp_path / "t.h5").write_bytes(data[: len(data) // 2])
        with unchanged(tmp_path):
            assert_failed(run_cli("preview", tmp_path / "t.h5", "-o", tmp_path / "p.exr"))

    def test_exr_renamed(self, run_cli, ws, tmp_path):
        (tmp_path / "m.h5").write_bytes((ws / "map.exr").read_bytes())
        with unchanged(tmp_path):
            assert_failed(run_cli("preview", tmp_path / "m.h5", "-o", tmp_path / "p.exr"),
                          fragment="not a readable HDF5 asset")  # fmt: skip

    def test_source_hash_mismatch(self, run_cli, ws, tmp_path):
        (tmp_path / "env.h5").write_bytes((ws / "env_sh.h5").read_bytes())
        with unchanged(tmp_path):
            assert_failed(run_cli("preview", tmp_path / "env.h5", "--diff", "--size", 8,
                                  "--source", ws / "other.exr", "-o", tmp_path / "p.exr"),
                          fragment="SHA-256")  # fmt: skip
