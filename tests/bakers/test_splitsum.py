"""The split-sum prefilter (:mod:`shbake.bakers.splitsum`): octahedral round trip, the DFG
product on a constant map, fireflies of a one-texel sun, refused configurations.
"""

import numpy as np
import pytest

from shbake.bakers.dfg import dfg_table
from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
from shbake.shading.dfg import dfg_lookup
from shbake.shading.splitsum import evaluate_splitsum
from shbake.texture.octahedral import decode as oct_decode
from shbake.texture.octahedral import encode as oct_encode
from tests.helpers import smooth_map
from tests.probe_cases import random_pairs


class TestSplitSum:
    def test_octahedral_round_trip(self):
        rng = np.random.default_rng(1)
        d = rng.normal(size=(500, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        for x in d:
            u, w = oct_encode(*x)
            np.testing.assert_allclose(oct_decode(u, w), x, atol=1e-12)

    @pytest.mark.parametrize("prefilter", ["plain", "filtered"])
    def test_constant_map_gives_dfg_product(self, prefilter):
        cfg = SplitSumConfig(top=32, min_size=8, alphas=(0.2, 0.5, 1.0), samples=256,
                             prefilter=prefilter)  # fmt: skip
        levels = prefilter_chain(np.full((16, 32, 3), 2.0, np.float32), cfg)
        for lv in levels:
            np.testing.assert_allclose(lv, 2.0, rtol=1e-6)
        table = dfg_table(size=8, samples=512)
        v, n = random_pairs(20, 3)
        out = evaluate_splitsum(levels, cfg.alphas, table, v, n, 0.3, (0.04,) * 3)
        a = dfg_lookup(table, np.einsum("ij,ij->i", v, n), 0.3)
        np.testing.assert_allclose(out[:, 0], 2.0 * (0.04 * a[:, 0] + 0.96 * a[:, 1]), rtol=1e-6)

    def test_filtered_prefilter_removes_sun_fireflies(self):
        """A one-texel sun: at 1024 samples the filtered prefilter is closer to the converged
        plain prefilter (2^17 samples) than the plain one at 1024 (the paper's baseline)."""
        img = smooth_map(64, sun=[2e3, 2e3, 2e3])
        kw = dict(top=16, min_size=16, alphas=(0.25, 0.5))
        ref = prefilter_chain(img, SplitSumConfig(**kw, samples=1 << 17))
        errs = {p: sum(np.mean((a - b) ** 2) for a, b in zip(
                    prefilter_chain(img, SplitSumConfig(**kw, prefilter=p)), ref, strict=True))
                for p in ("plain", "filtered")}  # fmt: skip
        assert errs["filtered"] < 0.5 * errs["plain"], errs

    def test_bad_config_refused(self):
        for kw in ({"alphas": (0.5, 0.2)}, {"alphas": (0.5,)}, {"alphas": (0.2, 1.5)},
                   {"prefilter": "box"}):  # fmt: skip
            with pytest.raises(ValueError):
                SplitSumConfig(**kw)
