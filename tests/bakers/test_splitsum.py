"""The split-sum prefilter (:mod:`shbake.bakers.splitsum`): octahedral round trip, the DFG
product on a constant map, fireflies of a one-texel sun, refused configurations, and both
prefilters against Karis' listing written out in numpy (every sample's texel).
"""

import numpy as np
import pytest

from shbake.bakers.dfg import dfg_table
from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
from shbake.envmap.importance import pyramid_levels
from shbake.shading.dfg import dfg_lookup
from shbake.shading.splitsum import evaluate_splitsum
from shbake.texture.octahedral import decode as oct_decode
from shbake.texture.octahedral import encode as oct_encode
from tests.helpers import smooth_map
from tests.probe_cases import random_pairs


def _karis_prefilter(pixels, alpha, size, samples, pyramid_levels=0):
    """Karis 2013's ``PrefilterEnvMap`` for every texel of a ``size²`` octahedral level, in
    numpy from the formulas: ``N = V`` the texel centre's direction (Cigolle et al. 2014),
    the GGX half vectors of a 2D Fibonacci lattice (Walter et al. 2007 eq. 35) in the
    branchless frame of Duff et al. 2017, ``L = 2(V·H)H − V``, ``Σ L(l) N·L / Σ N·L`` over
    ``N·L > 0``, ``L(l)`` the lat-long texel holding ``l`` (SPEC §3). With
    ``pyramid_levels``, filtered importance sampling (Křivánek & Colbert 2008): the level
    ``⌊½ log2(Ω_s / Ω_texel) + 1⌋`` of the solid-angle pyramid, ``Ω_s = 4/(N D(h))``."""
    h, w = pixels.shape[:2]
    pyramid = [pixels.astype(np.float64)]
    for _ in range(pyramid_levels - 1):  # 2x2 means weighted by the rows' solid angles
        p, rows = pyramid[-1], pyramid[-1].shape[0]
        band = -np.diff(np.cos(np.pi * np.arange(rows + 1) / rows))[:, None, None]
        q = (p * band).reshape(rows // 2, 2, -1, 2, 3).sum(axis=(1, 3))
        pyramid.append(q / (2.0 * band.reshape(rows // 2, 2).sum(1)[:, None, None]))
    uv = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    px, pz = np.meshgrid(uv, uv)  # columns: u, rows: w
    py = 1.0 - np.abs(px) - np.abs(pz)
    fold = py < 0.0
    px, pz = (np.where(fold, (1.0 - np.abs(pz)) * np.where(px >= 0.0, 1.0, -1.0), px),
              np.where(fold, (1.0 - np.abs(px)) * np.where(pz >= 0.0, 1.0, -1.0), pz))  # fmt: skip
    n = np.stack([px, py, pz], -1).reshape(-1, 1, 3)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    sign = np.where(n[..., 2:] >= 0.0, 1.0, -1.0)
    e = -1.0 / (sign + n[..., 2:])
    f = n[..., :1] * n[..., 1:2] * e
    t = np.concatenate([1.0 + sign * n[..., :1] ** 2 * e, sign * f, -sign * n[..., :1]], -1)
    b = np.concatenate([f, sign + n[..., 1:2] ** 2 * e, -n[..., 1:2]], -1)
    k = np.arange(samples)
    u, phi = (k + 0.5) / samples, 2.0 * np.pi * np.mod(k * (np.sqrt(5.0) - 1.0) / 2.0, 1.0)
    cos_h = np.sqrt((1.0 - u) / (1.0 - u + alpha**2 * u))[:, None]
    sin_h = np.sqrt(1.0 - cos_h**2)
    half = sin_h * (np.cos(phi)[:, None] * t + np.sin(phi)[:, None] * b) + cos_h * n
    light = 2.0 * cos_h * half - n
    n_dot_l = np.einsum("tkc,tkc->tk", light, n * np.ones_like(light))
    row = np.minimum((np.arccos(np.clip(light[..., 1], -1, 1)) / np.pi * h).astype(int), h - 1)
    col = np.mod(np.arctan2(light[..., 0], -light[..., 2]) / (2.0 * np.pi), 1.0) * w
    col = np.minimum(col.astype(int), w - 1)
    level = np.zeros_like(row)
    if pyramid_levels:
        d = alpha**2 / (np.pi * ((alpha**2 - 1.0) * cos_h[:, 0] ** 2 + 1.0) ** 2)
        omega_texel = 2.0 * np.pi / w * (np.cos(np.pi * row / h) - np.cos(np.pi * (row + 1) / h))
        lod = 0.5 * np.log2(4.0 / (samples * d) / omega_texel) + 1.0
        level = np.clip(np.floor(lod).astype(int), 0, pyramid_levels - 1)
    radiance = np.zeros(light.shape)
    for lv, img in enumerate(pyramid):
        at = level == lv
        radiance[at] = img[row[at] >> lv, col[at] >> lv]
    weight = np.where(n_dot_l > 0.0, n_dot_l, 0.0)
    out = np.einsum("tk,tkc->tc", weight, radiance) / weight.sum(1)[:, None]
    return out.reshape(size, size, 3)


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

    @pytest.mark.parametrize("prefilter", ["plain", "filtered"])
    @pytest.mark.parametrize("shape, chain", [((32, 64), (16, 8)), ((24, 48), (12, 9))])
    def test_every_sample_reads_the_texel_of_karis_listing(self, prefilter, shape, chain):
        """Texels of random values: a single sample of a texel (of 64) reading another map
        texel than the listing's moves its mean by ~1e-3, against 1e-6 allowed."""
        img = np.random.default_rng(7).uniform(0.2, 1.2, (*shape, 3)).astype(np.float32)
        cfg = SplitSumConfig(top=chain[0], min_size=chain[1], alphas=(0.08, 0.4, 0.9),
                             samples=64, prefilter=prefilter)  # fmt: skip
        levels = {"plain": 0, "filtered": pyramid_levels(shape)}[prefilter]
        for got, size, a in zip(prefilter_chain(img, cfg), cfg.sizes, cfg.alphas, strict=True):
            want = _karis_prefilter(img, a, size, cfg.samples, levels)
            np.testing.assert_allclose(got, want, rtol=1e-6)

    def test_bad_config_refused(self):
        for kw in ({"alphas": (0.5, 0.2)}, {"alphas": (0.5,)}, {"alphas": (0.2, 1.5)},
                   {"prefilter": "box"}):  # fmt: skip
            with pytest.raises(ValueError):
                SplitSumConfig(**kw)
