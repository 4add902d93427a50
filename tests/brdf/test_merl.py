"""Measured BRDFs (:mod:`shbake.brdf.merl`): a MERL file written from an analytic GGX reads back
as that model; a truncated file is refused; the digest kept is of the bytes decoded.
"""

import hashlib

import numpy as np
import pytest

from shbake.brdf import make_brdf, merl
from shbake.errors import FormatError, InputError
from tests.helpers import hemi


class TestMerl:
    def test_round_trip_of_analytic_model(self, merl_file):
        path, ggx = merl_file
        merl = make_brdf("merl", merl_path=str(path))
        s, v = hemi(2000), hemi(2000)
        ok = (s[:, 2] > 0.2) & (v[:, 2] > 0.2)
        a, m = ggx.evaluate(s[ok], v[ok]), merl.evaluate(s[ok], v[ok])
        rel = np.abs(m - a) / np.maximum(a, 1e-3)
        assert np.median(rel) < 0.01 and np.percentile(rel, 95) < 0.05

    def test_truncated_file_refused(self, merl_file, tmp_path):
        bad = tmp_path / "bad.binary"
        bad.write_bytes(merl_file[0].read_bytes()[:1000])
        with pytest.raises(InputError, match="truncated"):
            make_brdf("merl", merl_path=str(bad))

    def test_other_file_refused_without_echoing_it(self, tmp_path):
        """A scene may name any file as its MERL BRDF: its first bytes are not shown."""
        other = tmp_path / "passwd"
        other.write_bytes(b"root:x:0:0:root:/root:/bin/bash\n" * 4)
        with pytest.raises(InputError, match="not a MERL .binary file") as info:
            make_brdf("merl", merl_path=str(other))
        header = np.frombuffer(other.read_bytes()[:12], "<i4")
        assert not any(str(int(d)) in str(info.value) for d in header)


class TestReadMerl:
    def test_digest_is_of_the_bytes_decoded(self, merl_file):
        values, digest = merl.read_merl(str(merl_file[0]))
        assert digest == hashlib.sha256(merl_file[0].read_bytes()).hexdigest()
        assert values.shape == (3, merl.N_TH, merl.N_TD, merl.N_PD)

    def test_unchanged_file_read_once_changed_file_again(self, merl_file, tmp_path, monkeypatch):
        """A reference drawn in blocks builds its BRDF per block: the file is read once while
        it is unchanged, and read again (with its new digest) once it is rewritten."""
        from shbake import resources

        path = tmp_path / "m.binary"
        path.write_bytes(merl_file[0].read_bytes())
        reads = []
        read_bounded = resources.read_bounded
        monkeypatch.setattr(resources, "read_bounded",
                            lambda *a, **k: reads.append(a[0]) or read_bounded(*a, **k))
        first = [merl.read_merl(str(path))[1] for _ in range(3)]
        assert len(reads) == 1 and len(set(first)) == 1
        data = bytearray(path.read_bytes())
        data[-8:] = np.float64(0.5).tobytes()
        path.write_bytes(bytes(data))
        _, digest = merl.read_merl(str(path))
        assert len(reads) == 2 and digest == hashlib.sha256(bytes(data)).hexdigest() != first[0]


class TestMakeBrdfDigest:
    def test_recorded_digest_refuses_other_bytes(self, merl_file):
        """``merl_sha256`` (what an asset records) is checked on the bytes read, not on a
        second read of the path: the file decoded is the one the asset was baked from."""
        path = str(merl_file[0])
        want = hashlib.sha256(merl_file[0].read_bytes()).hexdigest()
        assert make_brdf("merl", path, want).source_sha256 == want
        with pytest.raises(FormatError, match="not the MERL file this asset was baked from"):
            make_brdf("merl", path, "ab" * 32)

    def test_table_records_the_bytes_it_baked(self, merl_file, tmp_path, monkeypatch):
        """A MERL file rewritten after the bake read it: the table records the digest of
        the bytes it tabulated, not of the file as it is afterwards."""
        from shbake.batch.brdf_table import bake_brdf_table
        from shbake.format.asset import read_asset

        path = tmp_path / "m.binary"
        path.write_bytes(merl_file[0].read_bytes())
        baked = hashlib.sha256(path.read_bytes()).hexdigest()
        read_merl = merl.read_merl

        def read_then_rewrite(p):
            out = read_merl(p)
            path.write_bytes(path.read_bytes()[:12] + bytes(path.stat().st_size - 12))
            return out

        monkeypatch.setattr(merl, "read_merl", read_then_rewrite)
        out = tmp_path / "t.h5"
        bake_brdf_table("merl", str(out), merl_path=str(path), lmax=2, size=(8, 8),
                        samples=64)  # fmt: skip
        assert hashlib.sha256(path.read_bytes()).hexdigest() != baked
        assert read_asset(str(out)).attrs["source_sha256"] == baked

