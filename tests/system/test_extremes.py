"""Stability at the extremes (``make test-extremes``): every baker on degenerate inputs.

Maps: black, constant, a one-texel 1e5 sun on a dim sky, a 1e-6 dim real map,
a tiny (4 × 8) and a large (1024 × 2048) map, texels near the float32 limit (3e38).
Settings: lmax 0 and 64, GGX width at both ends (SH-exp fit α 0.05 … 1, split-sum
α 0.0025 … 1, GGX tables 1e-4 … 1), exponents to 1e4, views grazing to 1e-4. Nothing
non-finite in any asset, and where a closed form exists the value is checked against it
(constant map: E = π c; black map: zeros).
"""

import json
import re

import numpy as np
import pytest

from shbake.bakers.env_sh import bake_env_sh
from shbake.bakers.shexp import FitConfig, FitPlan
from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
from shbake.batch.export import export_assets
from shbake.brdf import make_brdf
from shbake.brdf.tabulate import project_views, tabulate
from shbake.envmap import load_environment
from shbake.envmap.image_io import read_image
from shbake.format.asset import write_asset
from shbake.format.exports import TARGETS
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.shader import shader
from tests.faults import assert_failed, unchanged
from tests.helpers import ktx2_levels, map_path, write_test_exr

pytestmark = pytest.mark.extremes

H = 32


def _map(kind: str, h: int = H) -> np.ndarray:
    w = 2 * h
    if kind == "black":
        return np.zeros((h, w, 3))
    if kind == "constant":
        return np.full((h, w, 3), 0.75)
    if kind == "sun":
        px = np.full((h, w, 3), 0.01)
        px[h // 4, w // 3] = 1e5
        return px
    if kind == "dim":
        px, _ = read_image(str(map_path("sunset")))
        step = max(1, px.shape[0] // h)
        return px[::step, ::step][:h, :w] * 1e-6
    raise ValueError(kind)


MAPS = ("black", "constant", "sun", "dim")


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    folder = tmp_path_factory.mktemp("extremes")
    out = {k: str(write_test_exr(folder / f"{k}.exr", _map(k))) for k in MAPS}
    out["tiny"] = str(write_test_exr(folder / "tiny.exr", _map("constant", 4)))
    big = np.full((1024, 2048, 3), 0.5, np.float32)
    big[100, 200] = 1e5
    out["large"] = str(write_test_exr(folder / "large.exr", big))
    return out


def _finite(asset):
    for name, data in asset.datasets.items():
        assert np.all(np.isfinite(np.asarray(data, float))), name


class TestEnvShExtremes:
    @pytest.mark.parametrize("kind", MAPS + ("tiny",))
    @pytest.mark.parametrize("lmax", [0, 2, 64])
    @pytest.mark.parametrize("sun", [False, True])
    def test_finite_and_closed_forms(self, maps, kind, lmax, sun):
        env = load_environment(maps[kind], quiet=True)
        if kind == "tiny" and lmax == 64:
            lmax = 1  # a 4-row map holds two bands; higher lmax is aliasing by construction
        asset, _ = bake_env_sh(env, lmax=lmax, irradiance_lmax=min(lmax, 2), sun=sun)
        _finite(asset)
        dirs = fibonacci_sphere(256)
        e = shader(asset, "irradiance").irradiance(dirs)
        assert np.all(np.isfinite(e))
        if kind == "black":
            assert np.all(e == 0.0)
        if kind in ("constant", "tiny") and not sun:
            # E = π c for a constant radiance c (any lmax: only band 0 is non-zero)
            np.testing.assert_allclose(e, np.pi * 0.75, rtol=2e-3)

    def test_large_map_with_a_sun(self, maps):
        env = load_environment(maps["large"], quiet=True)
        asset, summary = bake_env_sh(env, lmax=2, sun=True)
        _finite(asset)
        assert summary["sun"]["extracted"]


class TestBrdfTableExtremes:
    @pytest.mark.parametrize(
        "model, params",
        [
            ("ashikhmin-shirley", {"nu": "1e4", "nv": "1e4"}),
            ("ashikhmin-shirley", {"nu": "1e4", "nv": "0"}),
            ("phong", {"n": "1e4"}),
            ("phong", {"n": "0"}),
            ("ggx", {"alpha_x": "1e-4", "alpha_y": "1e-4"}),
            ("ggx", {"alpha_x": "1", "alpha_y": "1"}),
        ],
    )
    def test_finite_tables_and_grazing_views(self, model, params):
        brdf = make_brdf(model, **params)
        table, _ = tabulate(brdf, 4, (8, 8), samples=64)
        assert np.all(np.isfinite(table))
        for z in (1e-1, 1e-2, 1e-3, 1e-4):
            v = np.array([[np.sqrt(1 - z * z), 0.0, z]])
            c, _ = project_views(brdf, v, 4, samples=64)
            assert np.all(np.isfinite(c)), z


class TestProbeExtremes:
    @pytest.mark.parametrize("kind", MAPS)
    @pytest.mark.parametrize("rough", [(0.05, 0.1), (0.9, 1.0)])  # GGX width α (its lowest)
    def test_shexp_fit_finite(self, maps, kind, rough):
        env = load_environment(maps[kind], quiet=True)
        config = FitConfig(alpha_min=rough[0], alpha_max=rough[1], alpha_count=3, sets=2,
                           samples=64, normals=16, views=16)  # fmt: skip
        probe = FitPlan(config, env.shape).fit(env.pixels)
        assert np.all(np.isfinite(probe.p)) and np.all(np.isfinite(probe.q))
        assert np.isfinite(probe.stats["log_rms"])

    @pytest.mark.parametrize("kind", MAPS)
    @pytest.mark.parametrize("rough", [(0.05, 0.1), (0.9, 1.0)])
    def test_splitsum_finite(self, maps, kind, rough):
        env = load_environment(maps[kind], quiet=True)
        config = SplitSumConfig(top=16, min_size=8, alphas=(rough[0] ** 2, rough[1] ** 2),
                                samples=64)  # fmt: skip
        for level in prefilter_chain(env.pixels, config):
            assert np.all(np.isfinite(level))
        if kind == "black":
            assert all(np.all(lv == 0) for lv in prefilter_chain(env.pixels, config))


def _json_numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _json_numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _json_numbers(v)
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield float(obj)


def _exported_finite(files):
    """Nothing non-finite in any exported file: JSON/glTF numbers, KTX2 halves, SH text."""
    for f in files:
        f = str(f)
        if f.endswith((".json", ".gltf")):
            with open(f) as fh:
                text = fh.read()
            assert "Infinity" not in text and "NaN" not in text, f
            assert all(np.isfinite(x) for x in _json_numbers(json.loads(text))), f
        elif f.endswith(".ktx2"):
            for lv in ktx2_levels(f):
                assert np.all(np.isfinite(lv)), f
        elif f.endswith(".txt"):
            nums = [float(x) for x in re.findall(r"[-+]?[\d.]+(?:e[-+]?\d+)?|inf|nan",
                                                  open(f).read().lower())]  # fmt: skip
            assert all(np.isfinite(x) for x in nums), f


SMALL_CUBES = {"size": 16, "floor": 4, "samples": 32}


class TestExportExtremes:
    """Every engine export of black, constant, sun (kept in the map and extracted), dim and
    tiny maps: finite files; constant maps give the closed forms."""

    @pytest.mark.parametrize("target", TARGETS)
    @pytest.mark.parametrize(
        "kind, sun",
        [
            ("black", False),
            ("constant", False),
            ("sun", False),
            ("sun", True),
            ("dim", False),
            ("tiny", False),
        ],
    )
    def test_finite_exports(self, maps, tmp_path, target, kind, sun):
        env = load_environment(maps[kind], quiet=True)
        asset, _ = bake_env_sh(env, lmax=2, irradiance_lmax=2, sun=sun)
        path = str(tmp_path / f"{kind}.h5")
        write_asset(path, asset)
        files = export_assets([path], target, str(tmp_path / "out"), many=True, **SMALL_CUBES)
        assert files
        _exported_finite(files)
        if kind == "constant" and target == "ktx2":
            # a constant radiance 0.75 prefilters to 0.75 at every level (RGB; A = 1)
            for lv in ktx2_levels(next(f for f in files if f.endswith(".ktx2")
                                        and "_dfg" not in f)):  # fmt: skip
                np.testing.assert_allclose(lv.reshape(-1, 4)[:, :3], 0.75, rtol=2e-3)
        if kind == "constant" and target == "threejs":
            data = json.loads(open(files[0]).read())
            probe = next(o for o in _objects(data["object"]) if o.get("type") == "LightProbe")
            sh = np.asarray(probe["sh"], float).reshape(9, 3)
            # LightProbe.sh is radiance SH: L00 = c sqrt(4π), the rest 0
            np.testing.assert_allclose(sh[0], 0.75 * np.sqrt(4 * np.pi), rtol=1e-4)
            assert np.all(np.abs(sh[1:]) < 1e-6)


def _objects(node):
    yield node
    for child in node.get("children", []):
        yield from _objects(child)


class TestHalfFloatOverflow:
    """Engine textures in half floats (Filament's R11F_G11F_B10F: 64512): values beyond their
    largest are clamped with one warning line (docs/EXPORTS.md), never written as Inf."""

    @pytest.mark.parametrize("target", ["ktx2", "filament"])
    def test_clamped_with_one_warning(self, tmp_path, capsys, target):
        px = np.full((32, 64, 3), 0.5)
        px[8:10, 20:24] = 1e7  # a patch far beyond half range at every mirror texel it covers
        m = write_test_exr(tmp_path / "hot.exr", px)
        env = load_environment(str(m), quiet=True)
        asset, _ = bake_env_sh(env, lmax=2, irradiance_lmax=2, sun=False)
        path = str(tmp_path / "hot.h5")
        write_asset(path, asset)
        capsys.readouterr()
        files = export_assets([path], target, str(tmp_path / "out"), many=True, **SMALL_CUBES)
        err = capsys.readouterr().err
        limit = "half-float maximum 65504" if target == "ktx2" else "R11F_G11F_B10F maximum 64512"
        lines = [ln for ln in err.splitlines() if limit in ln]
        assert len(lines) == (1 if target == "ktx2" else 2)  # filament: _ibl and _skybox
        assert lines[0].startswith("shbake: warning: ") and "clamped" in lines[0]
        if target == "ktx2":
            lv0 = ktx2_levels(next(f for f in files if f.endswith(".ktx2") and "_dfg" not in f))
            assert np.all(np.isfinite(lv0[0])) and lv0[0].max() == np.float32(65504.0)
        _exported_finite(files)

    def test_non_finite_refused(self, tmp_path):
        from shbake.errors import OutputError
        from shbake.format.images import clamp_to_half

        with pytest.raises(OutputError, match="non-finite"):
            clamp_to_half([np.array([[1.0, np.inf]])], str(tmp_path / "x.ktx2"))

    def test_in_range_levels_untouched(self, tmp_path, capsys):
        from shbake.format.images import clamp_to_half

        a = np.array([[-65504.0, 0.0, 65504.0]])
        out = clamp_to_half([a], str(tmp_path / "x.ktx2"))
        assert np.array_equal(out[0], a) and capsys.readouterr().err == ""


class TestDfgExtremes:
    def test_table_bounded_and_smooth_limit(self):
        from shbake.batch.plan_cache import cached_dfg_table
        from shbake.shading.dfg import dfg_lookup

        table = cached_dfg_table()  # the table every probe and export ships
        assert np.all(np.isfinite(table))
        a0, a1 = table[..., 0], table[..., 1]
        # directional albedos of a BRDF with F = 1 and F = Schlick's tail: 0 <= A1 <= A0 <= 1
        assert np.all(a1 >= 0) and np.all(a1 <= a0 + 1e-9) and np.all(a0 <= 1.0 + 1e-3)
        # the smoothest GGX seen head-on is a mirror: all light reflected, no Fresnel tail
        assert a0[-1, 0] == pytest.approx(1.0, abs=0.02) and a1[-1, 0] < 1e-3
        # look-ups beyond the table (grazing to 1e-4, α 0 and 1) stay finite and bounded
        for m in (1e-4, 1e-3, 1.0):
            for alpha in (0.0, 1e-4, 1.0):
                v = np.asarray(dfg_lookup(table, np.array([m]), np.array([alpha])))
                assert np.all(np.isfinite(v)) and np.all(v >= 0) and np.all(v <= 1.0 + 1e-3)


class TestShrmExtremes:
    """SHRMs at both ends: F 0 and 64, Phong exponents 0 and 1e4, GGX α 1e-4 and 1, on black,
    constant, sun, dim, tiny maps."""

    @pytest.mark.parametrize("kind", MAPS + ("tiny",))
    @pytest.mark.parametrize("brdf, params, F, P", [
        ("phong", {"n": "0"}, 0, 0), ("phong", {"n": "1e4"}, 64, 1),
        ("ggx", {"alpha": "1e-4"}, 16, 2), ("ggx", {"alpha": "1"}, 8, 2),
        ("phong-lobe", {"s": "1e4"}, 64, 0)])  # fmt: skip
    def test_finite(self, maps, kind, brdf, params, F, P):
        from shbake.bakers.shrm import bake_shrm
        from shbake.brdf.reflection import make_reflection_brdf

        env = load_environment(maps[kind], quiet=True)
        rb = make_reflection_brdf(brdf, params)
        b = bake_shrm(env, rb, 0.5, F, P, face_size=8)
        assert np.all(np.isfinite(b.cube)) and np.all(np.isfinite(b.coeffs.rho))
        if kind == "black":
            assert np.all(b.cube == 0)

    def test_constant_map_lobe_is_the_constant(self, maps):
        # the radially symmetric lobe integrates to 1 over the sphere: radiance c everywhere
        from shbake.bakers.shrm import bake_shrm
        from shbake.brdf.reflection import make_reflection_brdf
        from shbake.shading.shrm import reflection_cube

        env = load_environment(maps["constant"], quiet=True)
        b = bake_shrm(env, make_reflection_brdf("phong-lobe", {"s": "8"}), 0.5, 4, 0, 8)
        np.testing.assert_allclose(reflection_cube(b.cube, [0, 0, 1], "surface"), 0.75,
                                   rtol=1e-3)  # fmt: skip


class TestHugeAndTinyMaps:
    """The tiny (4 × 8) and the large (1024 × 2048, a 1e5 texel) map through the bakers the
    other classes run on 32-row maps: finite everywhere."""

    @pytest.mark.parametrize("kind", ["tiny", "large"])
    def test_splitsum_shrm_and_export(self, maps, tmp_path, kind):
        from shbake.bakers.shrm import bake_shrm
        from shbake.brdf.reflection import make_reflection_brdf

        env = load_environment(maps[kind], quiet=True)
        config = SplitSumConfig(top=16, min_size=8, alphas=(0.01, 1.0), samples=64)
        assert all(np.all(np.isfinite(lv)) for lv in prefilter_chain(env.pixels, config))
        b = bake_shrm(env, make_reflection_brdf("microfacet", {"sigma": "0.2"}), 0.5, 8, 2, 8)
        assert np.all(np.isfinite(b.cube))
        asset, _ = bake_env_sh(env, lmax=2, sun=kind == "large")
        path = str(tmp_path / f"{kind}.h5")
        write_asset(path, asset)
        _exported_finite(export_assets([path], "ktx2", str(tmp_path / "out"), many=True,
                                       **SMALL_CUBES))  # fmt: skip

    @pytest.mark.parametrize("kind", ["tiny", "large"])
    def test_shexp_fit(self, maps, kind):
        env = load_environment(maps[kind], quiet=True)
        config = FitConfig(alpha_min=0.05, alpha_max=1.0, alpha_count=3, sets=1, samples=64,
                           normals=16, views=16)  # fmt: skip
        probe = FitPlan(config, env.shape).fit(env.pixels)
        assert np.all(np.isfinite(probe.p)) and np.all(np.isfinite(probe.q))


class TestFloat32Limit:
    """Texels of 3e38, near the float32 limit (3.4e38): no sum over the map's texels
    overflows (float64 where float32 would) and no numpy warning escapes. The non-finite
    check of every map read (``envmap.repair.repair_nonfinite``) summed the map in float32
    ("overflow encountered in reduce" on every command), and the importance pyramid
    (``envmap.importance.latlong_pyramid``) summed texel pairs in float32: its levels held
    inf, and so did the filtered split-sum levels; on a map of such texels everywhere the
    SH-exp fit's targets were NaN (the probe refused as invalid). What a step makes beyond
    float32 from such texels is refused in one line naming the map and the step
    (:func:`shbake.conventions.to_float32`)."""

    @pytest.mark.parametrize("where", ["patches", "everywhere"])
    def test_no_overflow_and_no_warning(self, tmp_path, where):
        import warnings

        from shbake.envmap.importance import latlong_pyramid, level_offsets, pyramid_levels
        from shbake.envmap.layouts import latlong_solid_angles

        px = np.full((H, 2 * H, 3), 3e38 if where == "everywhere" else 0.5, np.float32)
        px[8:10, 20:22] = 3e38  # one texel of the pyramid's first level: a 2×2 mean of 3e38
        px[20, 40:44] = 3e38  # two pairs of one row: each pair's sum 6e38
        path = str(write_test_exr(tmp_path / "limit.exr", px))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            env = load_environment(path, quiet=True)
            assert env.pixels.max() == np.float32(3e38)
            levels = pyramid_levels(env.shape)
            offsets = level_offsets(env.shape, levels)
            pyramid = latlong_pyramid(env.pixels.reshape(-1, 3), env.shape, levels)
            totals = [
                np.einsum("pc,p->c", pyramid[offsets[k] : offsets[k + 1]].astype(float),
                          latlong_solid_angles(H >> k, 2 * H >> k).reshape(-1))
                for k in range(levels)
            ]  # fmt: skip
            np.testing.assert_allclose(totals, np.tile(totals[0], (levels, 1)), rtol=1e-6)
            config = FitConfig(alpha_min=0.05, alpha_max=1.0, alpha_count=3, sets=1,
                               samples=64, normals=16, views=16)  # fmt: skip
            probe = FitPlan(config, env.shape).fit(env.pixels)
            assert np.all(np.isfinite(probe.p)) and np.all(np.isfinite(probe.q))
            config = SplitSumConfig(top=16, min_size=8, alphas=(0.01, 1.0), samples=64,
                                    prefilter="filtered")  # fmt: skip
            assert all(np.all(np.isfinite(lv)) for lv in prefilter_chain(env.pixels, config))

    @pytest.mark.parametrize("command", ["shrm", "probe-eval", "project-env"])
    def test_stored_float32_overflow_is_one_line(self, tmp_path, run_cli, command):
        """A map of 3.4e38 everywhere: its SHRM coefficients (``L_00`` is ``√(4π)`` times
        the radiance) and its irradiance (``π`` times) are beyond float32. ``shrm`` refused
        the asset for "non-finite values", ``probe-eval`` printed "RuntimeWarning: overflow
        encountered in cast" (exit 0, its SHRM's errors inf) and ``project-env --exr-dir
        --float-exr`` refused "to write non-finite values"; each is one line naming the map
        and the step, exit 1, no warning, the old outputs byte-identical, nothing new."""
        path = write_test_exr(tmp_path / "limit.exr", np.full((H, 2 * H, 3), 3.4e38, np.float32))
        out = tmp_path / "out"
        out.mkdir()
        for name in ("old.h5", "old.md"):
            (out / name).write_text("old")
        args = {
            "shrm": ["shrm", path, "-o", out / "old.h5", "--brdf", "phong", "-p", "n=8"],
            "probe-eval": ["probe-eval", path, "--size", "8", "--samples", "32", "--roughness",
                           "0.5", "--face-size", "8", "-o", out / "old.md"],
            "project-env": ["project-env", path, "-o", out / "old.h5", "--exr-dir",
                            out / "maps", "--float-exr"],
        }[command]  # fmt: skip
        step = "the --exr-dir map irradiance.exr" if command == "project-env" else "the SHRM"
        with unchanged(tmp_path):
            result = run_cli(*args)
        assert_failed(result, 1, f"{path}: values too large to store in float32 after {step}")
        assert "warning" not in result[2], result[2]

    @pytest.mark.parametrize("target", ["webgl", "ktx2"])
    def test_export_of_an_asset_beyond_float32(self, tmp_path, run_cli, target):
        """An env_sh asset baked from a map of 3.4e38 everywhere holds irradiance SH beyond
        float32 (float64 in the asset): ``export --to webgl`` refused "KTX2 level has values
        that float32 cannot hold", naming no file. One line naming the asset and the
        texture, exit 1, no warning, the old export byte-identical; ``ktx2`` (half floats,
        clamped with a warning naming the asset) still writes."""
        path = write_test_exr(tmp_path / "limit.exr", np.full((H, 2 * H, 3), 3.4e38, np.float32))
        asset = tmp_path / "limit.h5"
        assert run_cli("project-env", path, "-o", asset, "-q")[0] == 0
        if target == "ktx2":
            code, _, err = run_cli("export", asset, "--to", "ktx2", "-o", tmp_path / "e.ktx2")
            assert code == 0 and "overflow" not in err, err
            return
        ok = write_test_exr(tmp_path / "ok.exr", np.ones((H, 2 * H, 3), np.float32))
        out = tmp_path / "web"
        assert run_cli("project-env", ok, "-o", tmp_path / "ok.h5", "-q")[0] == 0
        assert run_cli("export", tmp_path / "ok.h5", "--to", "webgl", "-o", out, "-q")[0] == 0
        with unchanged(tmp_path):
            result = run_cli("export", asset, "--to", "webgl", "-o", out)
        assert_failed(result, 1, f"{asset}: values too large to store in float32 after the "
                                 "webgl texture uIrradiance")  # fmt: skip
        assert "warning" not in result[2].lower(), result[2]

    @pytest.mark.parametrize("command", ["project-env", "shrm", "export"])
    def test_colour_conversion_overflow_is_one_line(self, tmp_path, run_cli, command):
        """A 3e38 ACEScg red texel is 5.1e38 in linear Rec.709: the conversion made it inf
        after the map's NaN/Inf check, and the bake refused its "invalid asset … non-finite
        values". It is refused at the conversion: one line naming the map and the conversion,
        exit 1, nothing written."""
        px = np.ones((H, 2 * H, 3), np.float32)
        px[8:10, 20:22] = (3e38, 0.0, 0.0)
        path = write_test_exr(tmp_path / "red.exr", px)
        output = {"project-env": "red.h5", "shrm": "red.h5", "export": "red.json"}[command]
        target = ["--to", "threejs"] if command == "export" else []
        with unchanged(tmp_path):
            result = run_cli(command, path, *target, "-o", tmp_path / output, "--colorspace",
                             "ACEScg")  # fmt: skip
        assert_failed(result, 1, f"{path}: values too large to store in float32 after the "
                                 "colour conversion from ACEScg to linear Rec.709 ")  # fmt: skip
        assert "warning" not in result[2], result[2]
