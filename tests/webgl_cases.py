"""The assets the WebGL shader tests render (tests/system/test_webgl_shaders.py), shared with
bench/shader_cost.py: small split-sum, SH-exp, SHRM and Kautz bakes and the glossy
materials they are drawn with."""

from shbake.bakers.shexp import FitConfig
from shbake.bakers.splitsum import SplitSumConfig

GLOSSY = [(r, f0) for r in (0.25, 0.5, 0.75, 1.0) for f0 in (1.0, 0.04)]
"""(perceptual roughness, F0) of the glossy passes: chrome and dielectric, r 0.25 … 1."""
SPLIT = SplitSumConfig(top=32, min_size=8, alphas=(0.0625, 0.25, 0.5, 1.0), samples=64)
"""A small split-sum chain over α = r² for r 0.25 … 1 (its values do not matter here)."""
FIT = FitConfig(normals=16, views=8, alpha_count=4, alpha_min=0.0625, polish=0, samples=64)
"""A quick SH-exp fit (two sets, lmax 5 and 2) over the same range."""
SHRMS = {
    "surface": ("ggx", {"alpha": 0.3, "F0": 1.0}, {"F": 6, "P": 2, "face_size": 16}),
    "lobe": ("phong-lobe", {"s": 32.0}, {"F": 10, "P": 0, "face_size": 16}),
    "tangent": ("kajiya-kay", {}, {"F": 8, "P": 4, "face_size": 8}),
}
"""One SHRM per kind (RH02 §7.5): GGX (P 2), a Phong lobe, Kajiya–Kay hair; small bakes."""
TABLES = {"ashikhmin-shirley": {"nu": 40.0, "nv": 4.0}, "phong": {}}
"""Kautz tables (lmax 4, 16² views, 64 samples): anisotropic Ashikhmin–Shirley (brushed
along the preview's meridians) and an analytic, MERL-free Phong."""
