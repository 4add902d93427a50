"""One valid, small asset of every registered kind, built by the kinds' own builders
(shared by tests/test_registry.py and tests/test_faults.py)."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from shbake.conventions import DFG_SIZE

MAP_SHAPE = (16, 32)


def write_map(path, seed: int = 0, scale: float = 1.0) -> Path:
    """A small positive lat-long EXR (float32) written with OpenImageIO directly."""
    import OpenImageIO as oiio

    rng = np.random.default_rng(seed)
    pixels = (scale * (0.5 + rng.random(MAP_SHAPE + (3,)))).astype(np.float32)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(MAP_SHAPE[1], MAP_SHAPE[0], 3, "float"))
    out.write_image(pixels)
    out.close()
    return Path(path)


def _dfg():
    g = np.linspace(0.1, 0.9, DFG_SIZE * DFG_SIZE * 2)
    return g.reshape(DFG_SIZE, DFG_SIZE, 2).astype(np.float32)


def example(kind: str, map_path) -> "object":
    """An in-memory asset of ``kind`` made from the map at ``map_path`` (no fitting)."""
    from shbake.bakers.env_sh import bake_env_sh
    from shbake.bakers.shexp import FitConfig
    from shbake.bakers.splitsum import SplitSumConfig
    from shbake.brdf.model import make_brdf
    from shbake.envmap import load_environment
    from shbake.format.kautz_table import build_table_asset
    from shbake.format.shexp import build_shexp_asset, build_shexp_set_asset
    from shbake.format.splitsum import build_splitsum_asset

    env = load_environment(str(map_path), quiet=True)
    if kind == "env_sh":
        asset, _ = bake_env_sh(env, lmax=3, provenance={"command_line": "shbake project-env"})
        asset.datasets["/sun/direction"] = np.array([0.0, 0.6, 0.8])
        asset.datasets["/sun/solid_angle"] = np.float64(0.01)
        asset.datasets["/sun/radiance"] = np.array([10.0, 9.0, 8.0])
        return asset
    if kind == "brdf_table":
        rng = np.random.default_rng(1)
        h = w = 4
        tables = rng.random((2, h, w, 9, 3)) * 0.1
        conv = SimpleNamespace(view_errors=np.full((h, w), 1e-4), error=1e-4, samples=64,
                               seconds=0.0)  # fmt: skip
        return build_table_asset(
            make_brdf("phong"), tables, [conv, conv], [("exponent", np.array([2.0, 8.0]))], 2,
            record_time=False,
        )  # fmt: skip
    config = FitConfig()
    n_p, n_q = (config.lmax_p + 1) ** 2, (config.lmax_q + 1) ** 2 - 1
    rng = np.random.default_rng(2)
    k = len(config.knots)
    probe = SimpleNamespace(p=rng.random((k, n_p, 3)), q=rng.random((k, n_q, 3)),
                            knots=np.asarray(config.knots, float),
                            stats={"log_rms": 0.1, "relative_rms": 0.1, "floored_targets": 0,
                                   "targets": 10})  # fmt: skip
    if kind == "shexp_probe":
        return build_shexp_asset(probe, config, _dfg(), env.meta)
    if kind == "shexp_probe_set":
        probes = [{"name": f"m{i}", "p": probe.p, "q": probe.q, "knots": probe.knots,
                   "stats": probe.stats, "meta": env.meta} for i in range(2)]  # fmt: skip
        return build_shexp_set_asset(probes, config, _dfg())
    if kind == "splitsum_probe":
        sc = SplitSumConfig(top=16, min_size=8, alphas=(0.25, 0.5, 1.0))
        levels = [rng.random((s, s, 3)) for s in sc.sizes]
        return build_splitsum_asset(levels, sc, _dfg(), env.meta)
    if kind == "shrm":
        from shbake.bakers.shrm import bake_shrm
        from shbake.brdf.reflection import make_reflection_brdf
        from shbake.format.shrm import build_shrm_asset

        bake = bake_shrm(env, make_reflection_brdf("ggx", {"alpha": 0.3, "F0": 1.0}), F=4, P=1,
                         face_size=4)  # fmt: skip
        return build_shrm_asset(bake, env.meta)
    raise KeyError(kind)
