"""Measured BRDFs (:mod:`shbake.brdf.merl`): a MERL file written from an analytic GGX reads back
as that model; a truncated file is refused.
"""

import numpy as np
import pytest

from shbake.brdf import make_brdf
from shbake.errors import InputError
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
