"""One valid, small asset of every registered kind, built by the kinds' own builders, and
the corrupt variants of them that readers must refuse (:data:`CORRUPTIONS`), shared by
tests/format/test_registry.py, tests/system/faults/ and tests/system/test_hostile_assets.py."""

from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np

from shbake.conventions import DFG_SIZE
from shbake.format.asset import write_asset

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
    from shbake.format.brdf_table import build_table_asset
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
            make_brdf("phong", n=2.0), tables, [conv, conv], [("n", np.array([2.0, 8.0]))], 2,
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


# -- corrupt assets ---------------------------------------------------------------------


def _mutate(path, fn):
    with h5py.File(path, "r+") as f:
        fn(f)


def _replace(name, data):
    def fn(f):
        attrs = dict(f[name].attrs) if name in f else {}
        del f[name]
        f[name] = data
        f[name].attrs.update(attrs)

    return fn


def _set_attr(name, value):
    def fn(f):
        f.attrs[name] = value

    return fn


def _del(name):
    def fn(f):
        if name.startswith("/"):
            del f[name]
        else:
            del f.attrs[name]

    return fn


NAN3 = np.array([np.nan, 0.0, 1.0])


def _group_at(path):
    """A group where the kind declares the dataset ``path`` (the dataset removed, if any)."""

    def fn(f):
        if path in f:
            del f[path]
        f.create_group(path)

    return fn


def _lights(direction, irradiance, keep_sun=False, radii=None):
    """Replace the example's sun by fitted lights (``/lights``) with these values (sphere
    lights with ``radii``)."""

    def fn(f):
        if not keep_sun:
            del f["/sun"]
        if radii is not None:
            f["/lights/angular_radius"] = np.asarray(radii, dtype=np.float64)
        if direction is not None:
            f["/lights/direction"] = np.asarray(direction, dtype=np.float64)
            attrs = {"requested": "auto", "fit_directions": 4096, "fit_mean_error": 0.01}
            f["/lights/direction"].attrs.update(attrs | {"fit_max_error": 0.1})
        f["/lights/irradiance"] = np.asarray(irradiance, dtype=np.float64)

    return fn


CORRUPTIONS = {
    # id: (kind, mutation, message fragment)
    "wrong-kind": ("env_sh", _set_attr("kind", "nope"), "kind 'nope' is unknown"),
    "kind-array": ("env_sh", _set_attr("kind", np.array([b"env_sh", b"x"])), "kind an array"),
    "newer-version": ("env_sh", _set_attr("format_version", np.int64(99)), "format_version 99"),
    "older-version": ("env_sh", _set_attr("format_version", np.int64(1)), "format_version 1"),
    "version-array": ("env_sh", _set_attr("format_version", np.arange(40)), "format_version an"),
    "format-array": ("env_sh", _set_attr("format", np.array([1, 2])), "not a shbake asset"),
    "missing-dataset": ("env_sh", _del("/lighting/band_energy"), "missing dataset"),
    "irradiance-9x1": ("env_sh", _replace("/irradiance/sh", np.zeros((9, 1))), "shape"),
    "irradiance-10x3": ("env_sh", _replace("/irradiance/sh", np.zeros((10, 3))), "shape"),
    "irradiance-1d": ("env_sh", _replace("/irradiance/sh", np.zeros(27)), "shape"),
    "irradiance-empty": ("env_sh", _replace("/irradiance/sh", np.zeros((0, 3))), "shape"),
    "irradiance-scalar": ("env_sh", _replace("/irradiance/sh", 1.0), "shape"),
    "irradiance-int": ("env_sh", _replace("/irradiance/sh", np.zeros((9, 3), int)), "float64"),
    "irradiance-complex": ("env_sh", _replace("/irradiance/sh", np.zeros((9, 3), complex)),
                           "float64"),
    "irradiance-string": ("env_sh", _replace("/irradiance/sh", "abc"), "float64"),
    "lighting-nan": ("env_sh", lambda f: f["/lighting/sh"].__setitem__((0, 0), np.nan),
                     "non-finite"),
    "sun-2": ("env_sh", _replace("/sun/direction", np.array([0.0, 1.0])), "sun/direction"),
    "sun-nan": ("env_sh", _replace("/sun/direction", NAN3), "non-finite"),
    "sun-not-unit": ("env_sh", _replace("/sun/direction", np.array([0.0, 2.0, 0.0])),
                     "unit vector"),
    "sun-partial": ("env_sh", _del("/sun/radiance"), "missing dataset /sun/radiance"),
    "sun-no-direction": ("env_sh", _del("/sun/direction"), "missing dataset /sun/direction"),
    "lights-not-unit": ("env_sh", _lights([[0.0, 2.0, 0.0]], [[1.0, 1.0, 1.0]]), "unit vector"),
    "lights-negative": ("env_sh", _lights([[0.0, 1.0, 0.0]], [[1.0, -1.0, 1.0]]), "negative"),
    "lights-no-direction": ("env_sh", _lights(None, [[1.0, 1.0, 1.0]]),
                            "missing dataset /lights/direction"),
    "lights-count-differs": ("env_sh", _lights([[0.0, 1.0, 0.0]], [[1.0] * 3, [2.0] * 3]),
                             "lights/irradiance"),
    "lights-and-sun": ("env_sh", _lights([[0.0, 1.0, 0.0]], [[1.0] * 3], keep_sun=True),
                       "not both"),
    "radius-group": ("env_sh", _group_at("/lights/angular_radius"), "is a group, not a dataset"),
    "irradiance-group": ("env_sh", _group_at("/irradiance/sh"), "is a group, not a dataset"),
    **{f"radius-{name}": ("env_sh", _lights(direction, [[1.0] * 3], radii=radii), fragment)
       for name, direction, radii, fragment in (
           ("negative", [[0.0, 1.0, 0.0]], [-0.1], "outside [0, π/3]"),
           ("wide", [[0.0, 1.0, 0.0]], [np.pi / 3 + 1e-9], "outside [0, π/3]"),
           ("near-hemisphere", [[0.0, 1.0, 0.0]], [1.5707963], "outside [0, π/3]"),
           ("nan", [[0.0, 1.0, 0.0]], [np.nan], "non-finite"),
           ("2d", [[0.0, 1.0, 0.0]], [[0.1]], "angular_radius"),
           ("count-differs", [[0.0, 1.0, 0.0]], [0.1, 0.2], "angular_radius"),
           ("no-direction", None, [0.1], "missing dataset /lights"),
       )},
    "knots-equal": ("shexp_probe", _replace("/knots", np.array([0.5, 0.5])), "/knots must"),
    "knots-negative": ("shexp_probe", _replace("/knots", np.array([-1.0, 0.5])), "/knots must"),
    "matrix-333": ("env_sh", _replace("/tangent_irradiance/matrix", np.zeros((3, 3, 3))),
                   "shape"),
    "lmax-attr-string": ("env_sh", lambda f: f["/lighting/sh"].attrs.__setitem__("lmax", "x"),
                         "must be an integer"),
    "probe-dfg-222": ("shexp_probe", _replace("/dfg", np.zeros((2, 2, 2), np.float32)), "shape"),
    "probe-dfg-nan": ("shexp_probe", lambda f: f["/dfg"].__setitem__((0, 0, 0), np.nan),
                      "non-finite"),
    "probe-range-missing": ("shexp_probe", _del("alpha_range"), "alpha_range"),
    "probe-range-not-json": ("shexp_probe", _set_attr("alpha_range", "[0.2,"),
                             "not valid JSON"),
    "probe-config-not-json": ("shexp_probe", _set_attr("fit_config", "{"), "not valid JSON"),
    "probe-p-float64": ("shexp_probe", _replace("/p", np.zeros((2, 36, 3))), "float32"),
    "set-count-missing": ("shexp_probe_set", _del("probe_count"), "probe_count"),
    "set-count-wrong": ("shexp_probe_set", _set_attr("probe_count", np.int64(5)), "5"),
    "levels-0": ("splitsum_probe", _set_attr("levels", np.int64(0)), "levels = 0"),
    "levels-minus-1": ("splitsum_probe", _set_attr("levels", np.int64(-1)), "levels = -1"),
    "levels-missing": ("splitsum_probe", _del("levels"), "levels"),
    "level-missing": ("splitsum_probe", _del("/levels/1"), "missing dataset /levels/1"),
    "table-axes-missing": ("brdf_table", lambda f: f["/table"].attrs.__delitem__("axes"),
                           "axes"),
    "table-model-missing": ("brdf_table", _del("brdf_model"), "brdf_model"),
    "table-axis-missing": ("brdf_table", _del("/axes/n"), "/axes/n"),
    "table-3d": ("brdf_table", _replace("/table", np.zeros((4, 4, 9), np.float32)), "axes"),
}  # fmt: skip


def corrupt(case: str, map_path, folder) -> tuple[str, str]:
    """Write the asset of ``case`` corrupted; return (path, expected message fragment)."""
    kind, fn, fragment = CORRUPTIONS[case]
    path = str(Path(folder) / f"{case}.h5")
    write_asset(path, example(kind, map_path))
    _mutate(path, fn)
    return path, fragment
