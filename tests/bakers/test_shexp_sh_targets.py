"""SH-lighting fit targets (:mod:`shbake.bakers.shexp_sh_targets`, ``probe-fit --targets sh``)
against converged GGX quadrature: where the band limit suffices, and where it does not.
"""

import json

import numpy as np

from shbake.format.asset import read_asset
from shbake.reference.ggx import ggx_integrals
from tests.helpers import smooth_map
from tests.probe_cases import random_pairs


class TestShTargets:
    def test_matches_quadrature_where_band_limit_suffices(self):
        """SH lighting × GGX tables against converged quadrature: rough targets agree
        (the map's SH to lmax 8 carries the lobe), sharp ones do not (band limit)."""
        from shbake.bakers.shexp_sh_targets import ShTargets

        img = smooth_map(64, sun=[40.0, 30.0, 20.0])
        v, n = random_pairs(40, 11)
        for r, bound in ((1.0, 5e-3), (0.36, 2e-2)):
            rough = np.full(len(v), r)
            ref, _ = ggx_integrals(img, v, n, rough, 1 << 16)
            got = ShTargets(v, n, rough, lmax=8, samples=2048).e0(img)
            assert np.sqrt(np.mean((got / ref - 1) ** 2)) < bound
        sharp = np.full(len(v), 0.04)
        ref, _ = ggx_integrals(img, v, n, sharp, 1 << 16)
        got = ShTargets(v, n, sharp, lmax=8, samples=2048).e0(img)
        assert np.sqrt(np.mean((got / ref - 1) ** 2)) > 1e-2  # the documented limit

    def test_cli_choice(self, probe_maps, tmp_path, run_cli):
        code, out, _ = run_cli("probe-fit", probe_maps[0], "--out-dir", tmp_path, "--normals", "16",
                               "--views", "16", "--targets", "sh", "--json", "-q")  # fmt: skip
        assert code == 0 and json.loads(out)["config"]["targets"] == "sh"
        asset = read_asset(str(tmp_path / "m0.h5"), ("shexp_probe",))
        assert np.all(np.isfinite(asset["/p"])) and np.all(np.isfinite(asset["/q"]))
