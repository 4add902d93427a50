"""shbake's GLSL passes (``shbake/shaders/``) rendered in WebGL2 equal the numba preview.

Each asset is exported with ``shbake export --to webgl``; the page
``tests/engines/pages/webgl.html`` loads the folder with the loader it carries
(``shbake_webgl.mjs``) and draws every pass with the preview's camera (orthographic from
+Z, pixel centres as :func:`shbake.preview.sphere.sphere_geometry`) into a float32 render
target in headless Chromium (WebGL2 on SwiftShader, ``tests/engines/harness.mjs``). The
image is compared pixel by pixel with ``shbake preview``'s pass of the same asset and
material: the registry's shader of the technique (:func:`shbake.shading.shader.shader`)
drawn by :func:`shbake.preview.passes.render_pass`, as :mod:`shbake.batch.preview` does
(float32 textures
within :data:`FLOAT_TOL` relative RMS over the sphere). Half-float textures (the export's
float32 texels rewritten as RGBA16F KTX2 in a copy) are measured against the bound half
precision implies (:func:`half_bound`). The textures are KTX 2.0 files, read here by the
specification (:func:`read_ktx2`) and by ktx-parse (``tests/engines/ktx2_read.mjs``) and
compared with the asset's data; the loader refuses a KTX2 it does not read, naming it.
Broken conventions — a texture's rows flipped, two SH bands swapped, a Condon–Shortley
sign added to the GLSL basis — make the comparison fail.
The viewer page (``index.html``) opens without a WebGL error and draws a non-black sphere.
``@pytest.mark.slow``: the six shared maps (``make test`` renders forest).
"""

import base64
import json
import os
import re
import shutil
import struct

import numpy as np
import pytest

from shbake.bakers.env_sh import bake_env_sh
from shbake.bakers.shrm import bake_shrm
from shbake.batch.brdf_table import bake_brdf_table
from shbake.batch.export import export_assets
from shbake.batch.probe_eval import bake_splitsum_file
from shbake.batch.probe_fit import fit_probes
from shbake.brdf.reflection import make_reflection_brdf
from shbake.conventions import DFG_MU_MIN, ROUGHNESS_MIN
from shbake.envmap import load_environment
from shbake.format.asset import read_asset, write_asset
from shbake.format.brdf_table import table_at
from shbake.format.exports.webgl import MAX_LIGHTS as SHBAKE_MAX_LIGHTS
from shbake.format.shrm import build_shrm_asset
from shbake.preview.passes import render_pass
from shbake.preview.sphere import sphere_geometry
from shbake.sh.basis import real_sh
from shbake.shading.shader import shader
from tests.engine_browser import decode
from tests.helpers import ROOT, SHARED_MAPS, map_path
from tests.webgl_cases import FIT, GLOSSY, SHRMS, SPLIT, TABLES

pytestmark = pytest.mark.xdist_group("webgl-shaders")
"""One worker runs this module (``make test``: ``--dist loadgroup``): one browser, each
map's assets baked once."""
SIZE = 48
"""Render edge (pixels): 1 800 sphere pixels per pass."""
FAST_MAPS = ("forest",)
FLOAT_TOL = 1e-3
"""Relative RMS over the sphere, float32 textures (issue 30)."""
HALF_EPS = 2.0**-11
"""Unit roundoff of IEEE half floats (10 stored mantissa bits)."""
FIXED = ("kautz-fixed-light", "kautz-fixed-view")
KAUTZ_MODES = [
    pytest.param("phong", ("kautz", *FIXED), id="phong"),
    pytest.param("ashikhmin-shirley", ("kautz",), id="ashikhmin-shirley"),
    pytest.param("ashikhmin-shirley", FIXED, marks=pytest.mark.slow, id="ashikhmin-shirley-fixed"),
]
"""The three modes of each table; the fixed modes' per-pixel store takes SwiftShader ~18 s a
mode (25 layers, each a draw), so ``make test`` runs them on one table."""
SHADERS = ROOT / "shbake" / "shaders"


def _maps():
    return [
        pytest.param(m, marks=() if m in FAST_MAPS else pytest.mark.slow, id=m) for m in SHARED_MAPS
    ]


def relative_rms(got: np.ndarray, want: np.ndarray) -> float:
    """``sqrt(Σ (got − want)² / Σ want²)`` over the pixels either image covers."""
    m = np.any(want != 0.0, axis=-1) | np.any(got != 0.0, axis=-1)
    return float(np.sqrt(np.sum((got - want)[m] ** 2) / np.sum(want[m] ** 2)))


@pytest.fixture(scope="module", params=_maps())
def exported(request, tmp_path_factory):
    """A map's env_sh asset (lmax 4, sun extracted), split-sum and SH-exp probes and
    :data:`SHRMS`, each exported; the :data:`TABLES` exported with the env_sh lighting."""
    name = request.param
    d = tmp_path_factory.mktemp(f"webgl-{name}")
    env = load_environment(str(map_path(name)), quiet=True)
    asset, _ = bake_env_sh(env, lmax=4, irradiance_lmax=4, sun=True)
    env_h5 = str(d / f"{name}-env.h5")
    write_asset(env_h5, asset)
    split_h5 = str(d / f"{name}-splitsum.h5")
    bake_splitsum_file(str(map_path(name)), split_h5, SPLIT)
    fit_probes([str(map_path(name))], out_dir=str(d), config=FIT)  # d/NAME.h5
    out = {"name": name, "env": env_h5, "splitsum": split_h5, "shexp": str(d / f"{name}.h5")}
    for kind, (model, params, orders) in SHRMS.items():
        out[f"shrm-{kind}"] = str(d / f"{name}-shrm-{kind}.h5")
        bake = bake_shrm(env, make_reflection_brdf(model, params), **orders)
        write_asset(out[f"shrm-{kind}"], build_shrm_asset(bake, env.meta))
    for model, params in TABLES.items():
        out[f"kautz-{model}"] = str(d / f"{model}.h5")
        bake_brdf_table(model, out[f"kautz-{model}"], params, lmax=4, size=(16, 16), samples=64)
    for key in ("env", "splitsum", "shexp", *(f"shrm-{k}" for k in SHRMS)):
        export_assets([out[key]], "webgl", str(d / f"{key}-webgl"))
        out[key + "_dir"] = str(d / f"{key}-webgl")
    for model in TABLES:
        key = f"kautz-{model}"
        export_assets([out[key]], "webgl", str(d / f"{key}-webgl"), env_path=env_h5)
        out[key + "_dir"] = str(d / f"{key}-webgl")
    return out


def render(browser, folder: str, jobs: list[dict]) -> dict:
    """Draw ``jobs`` (name, pass, GGX ``alpha``, ``f0``) from an export folder: name → RGB."""
    answer = browser.call("webgl.html", {"dir": browser.url(folder) + "/", "size": SIZE,
                                         "jobs": jobs})  # fmt: skip
    bad = [c for c in answer["console"] if c.startswith(("error", "pageerror", "http"))]
    assert not bad and answer["result"]["glError"] == 0, bad
    return {k: decode(v, SIZE)[..., :3].astype(np.float64)
            for k, v in answer["result"]["images"].items()}  # fmt: skip


def preview(asset, technique: str | None = None, material: dict | None = None, **companions):
    """The preview's image of ``asset`` through the registry's shader ``technique`` (default:
    the kind's), as ``shbake preview`` draws it (:mod:`shbake.batch.preview`)."""
    sh = shader(asset, technique, **companions)
    return render_pass(sh, SIZE, sh.check(**material) if material else None)[0]


ENV_PASSES = {"irradiance": "irradiance", "tangent-matrix": "tangent", "tangent-sh": "tangent-sh"}
"""GLSL pass → the registry technique it twins (the irradiance, the Mehta matrix and SH
tangent forms)."""


def env_previews(h5: str) -> dict:
    """The preview's irradiance, tangent (matrix form) and tangent-sh passes."""
    asset = read_asset(h5)
    return {gl: preview(asset, technique) for gl, technique in ENV_PASSES.items()}


ENV_JOBS = [{"name": p, "pass": p} for p in ("irradiance", "tangent-matrix", "tangent-sh")]


def glossy_jobs(pass_name: str) -> list[dict]:
    """The :data:`GLOSSY` materials of a glossy pass."""
    return [{"name": f"r{r}-f{f0}", "pass": pass_name, "alpha": r * r, "f0": [f0] * 3}
            for r, f0 in GLOSSY]  # fmt: skip


def glossy_previews(h5: str, pass_name: str) -> dict:
    """The preview's glossy pass of a probe for every :func:`glossy_jobs` material."""
    asset = read_asset(h5)
    return {j["name"]: preview(asset, pass_name, {"alpha": j["alpha"], "f0": j["f0"][0]})
            for j in glossy_jobs(pass_name)}  # fmt: skip


def test_glsl_constants_are_shbakes():
    """The numbers the GLSL files restate are the Python ones."""
    from shbake.bakers.env_lights import MAX_LIGHTS

    text = "".join(p.read_text() for p in SHADERS.glob("*.glsl"))

    def const(name):
        return float(re.search(rf"const \w+ {name} = ([^;]+);", text).group(1))

    assert const("SHBAKE_MAX_LIGHTS") == MAX_LIGHTS
    assert const("SHBAKE_DFG_MU_MIN") == DFG_MU_MIN
    assert const("SHBAKE_ROUGHNESS_MIN") == ROUGHNESS_MIN
    assert const("SHBAKE_PI") == pytest.approx(np.pi, rel=1e-14)


def test_docs_snippet_is_the_loader():
    """docs/SHADERS.md's "use it in your engine" block is the loader's text, verbatim."""
    loader = (SHADERS / "shbake_webgl.mjs").read_text()
    m = re.search(r"// BEGIN snippet webgl\n(.*?)// END snippet webgl", loader, re.S)
    assert m and 15 <= m.group(1).count("\n") <= 25
    assert "```js\n" + m.group(1) + "```" in (ROOT / "docs" / "SHADERS.md").read_text()


def test_registry_shaders_name_their_glsl():
    """Each registry shader of an asset kind names its GLSL twin (``Shader.glsl``): a
    function that file defines, shipped by ``--to webgl`` with one of the shader's kinds
    (``ggx-shrm``, made from baked arrays, has none)."""
    from shbake.format.exports.webgl import SHADERS as FILES_OF_KIND
    from shbake.shading.shader import shader_classes

    for name, cls in shader_classes().items():
        if not cls.kinds:
            assert cls.glsl == "", name
            continue
        file, function = cls.glsl.split(":")
        assert re.search(rf"^vec3 {function}\(", (SHADERS / file).read_text(), re.M), name
        assert any(file in FILES_OF_KIND.get(k, ()) for k in cls.kinds), name


class TestRenderedEqualsPreview:
    def test_env_sh_passes(self, engine_browser, exported):
        got = render(engine_browser, exported["env_dir"], ENV_JOBS)
        want = env_previews(exported["env"])
        errors = {k: relative_rms(got[k], want[k]) for k in want}
        assert max(errors.values()) <= FLOAT_TOL, errors

    @pytest.mark.parametrize("pass_name", ["splitsum", "shexp"])
    def test_glossy_pass(self, engine_browser, exported, pass_name):
        got = render(engine_browser, exported[pass_name + "_dir"], glossy_jobs(pass_name))
        want = glossy_previews(exported[pass_name], pass_name)
        errors = {k: relative_rms(got[k], want[k]) for k in want}
        assert max(errors.values()) <= FLOAT_TOL, errors

    @pytest.mark.parametrize("kind", sorted(SHRMS))
    def test_shrm_pass(self, engine_browser, exported, kind):
        """Surface kinds: where a mirror direction ties two cube faces exactly (the preview
        sphere's diagonal pixels), float32 and float64 may pick different faces, and the
        seam-correct fetch agrees across an edge to second order only (texture/cube.py):
        1.3e-5 (GGX) and 1.6e-4 (Phong lobe, s 32) relative RMS at face 16 on forest."""
        got = render(engine_browser, exported[f"shrm-{kind}_dir"], [{"name": "s", "pass": "shrm"}])
        want = preview(read_asset(exported[f"shrm-{kind}"]), "shrm")
        assert relative_rms(got["s"], want) <= FLOAT_TOL

    @pytest.mark.parametrize("model, modes", KAUTZ_MODES)
    def test_kautz_modes(self, engine_browser, exported, model, modes):
        """Full (rotate per pixel), fixed light (M(R)L stored per pixel by a first pass) and
        fixed view (M(R)ᵀc(v) stored): each equals the preview's image."""
        key = f"kautz-{model}"
        got = render(
            engine_browser, exported[key + "_dir"], [{"name": m, "pass": m} for m in modes]
        )
        table = table_at(read_asset(exported[key]))
        want = preview(read_asset(exported["env"]), "kautz", table=table)
        errors = {m: relative_rms(got[m], want) for m in modes}
        assert max(errors.values()) <= FLOAT_TOL, errors


def copy_export(folder: str, dest) -> str:
    shutil.copytree(folder, dest)
    return str(dest)


KTX2_IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"
"""KTX 2.0 spec §3.1."""
KTX2_TEXEL_TYPE = {109: "<f4", 97: "<f2"}
"""``VK_FORMAT_R32G32B32A32_SFLOAT``, ``VK_FORMAT_R16G16B16A16_SFLOAT`` → texel channel type."""


def read_ktx2(path: str) -> tuple[np.ndarray, int]:
    """An export's texture read by the KTX 2.0 specification, not by shbake's writer: the
    header (§3.2: nine uint32 after the identifier) says one RGBA float level, 2D
    (``layerCount`` 0) or a 2D array, no supercompression; the level index (§3.7, at byte
    80) places level 0. Texels ``([layers,] height, width, 4)`` and level 0's offset."""
    data = open(path, "rb").read()
    assert data[:12] == KTX2_IDENTIFIER, path
    vk, type_size, w, h, depth, layers, faces, levels, scheme = struct.unpack_from("<9I", data, 12)
    texel = np.dtype(KTX2_TEXEL_TYPE[vk])
    assert (type_size, depth, faces, levels, scheme) == (texel.itemsize, 0, 1, 1, 0), path
    offset, length, uncompressed = struct.unpack_from("<3Q", data, 80)
    shape = ((layers,) if layers else ()) + (h, w, 4)
    assert length == uncompressed == texel.itemsize * np.prod(shape)
    assert offset + length <= len(data)
    return np.frombuffer(data, texel, np.prod(shape), offset).reshape(shape), offset


def edit_texture(folder: str, name: str, edit, half: bool = False) -> None:
    """Replace texture ``name`` of an export by ``edit(texels)`` (``([L,] H, W, 4)`` float32),
    in place, or (``half``) as an RGBA16F KTX2 of the same shape."""
    from shbake.format.exports.ktx2 import encode_ktx2

    manifest = json.loads(open(os.path.join(folder, "shbake.json")).read())
    path = os.path.join(folder, manifest["textures"][name]["file"])
    texels, offset = read_ktx2(path)
    new = np.asarray(edit(texels.astype(np.float32)))
    if half:
        payload = encode_ktx2([new], False, type_size=2, layered=new.ndim == 4)
    else:
        payload = bytearray(open(path, "rb").read())
        payload[offset : offset + new.size * 4] = new.astype("<f4").tobytes()
    open(path, "wb").write(payload)


def _flip_levels(sizes):
    """An edit reversing the rows of each split-sum level (``sizes[k]`` texels in layer k)."""

    def edit(levels):
        out = levels.copy()
        for k, n in enumerate(sizes[: levels.shape[0]]):
            out[k, :n, :n] = levels[k, :n, :n][::-1]
        return out

    return edit


def _swap_band_one(coeffs):
    """SH coefficients 1 and 3 (``y_1,−1 ∝ y`` and ``y_1,1 ∝ x``) exchanged."""
    out = coeffs.copy()
    out[0, [1, 3]] = coeffs[0, [3, 1]]
    return out


CS_SIGN = (
    "float s2q = 1.4142135623730951 * q;",
    "float s2q = ((m & 1) == 1 ? -1.0 : 1.0) * 1.4142135623730951 * q;",
)
"""common.glsl's basis given the Condon–Shortley phase ``(−1)^m`` shbake does not use."""


class TestBrokenConventionFails:
    """Each fault, applied to a copy of the export, pushes the error far past the bound."""

    @pytest.mark.parametrize("fault", ["flipped rows", "swapped band", "Condon-Shortley sign"])
    def test_fault(self, engine_browser, exported, tmp_path, fault):
        if fault == "flipped rows":
            folder = copy_export(exported["splitsum_dir"], tmp_path / "x")
            sizes = json.loads(open(os.path.join(folder, "shbake.json")).read())["uniforms"]
            edit_texture(folder, "uLevels", _flip_levels(sizes["uLevelSize"]["value"]))
            got = render(engine_browser, folder, glossy_jobs("splitsum")[:1])
            want = glossy_previews(exported["splitsum"], "splitsum")
        else:
            folder = copy_export(exported["env_dir"], tmp_path / "x")
            if fault == "swapped band":
                edit_texture(folder, "uIrradiance", _swap_band_one)
            else:
                path = os.path.join(folder, "common.glsl")
                text = open(path).read()
                assert CS_SIGN[0] in text
                open(path, "w").write(text.replace(*CS_SIGN))
            got = render(engine_browser, folder, ENV_JOBS[:1])
            want = env_previews(exported["env"])
        name = next(iter(got))
        assert relative_rms(got[name], want[name]) > 10 * FLOAT_TOL


@pytest.fixture(scope="module")
def sphere_export(tmp_path_factory):
    """An env_sh asset with two sphere lights (``--light-shape sphere``, radii near 12° and
    25°: a sky with two discs; irradiance and tangent irradiance) and its ``--to webgl``
    folder."""
    from shbake.envmap.layouts import latlong_directions
    from tests.helpers import write_test_exr

    d = tmp_path_factory.mktemp("webgl-spheres")
    dirs = latlong_directions(64, 128)
    img = 0.2 + 0.1 * dirs[..., 1:2] * np.ones(3)
    for s, radius, radiance in (([0.6, 0.0, 0.8], 12.0, 60.0), ([0.0, 0.6, -0.8], 25.0, 8.0)):
        img = np.where(((dirs @ np.array(s)) > np.cos(np.radians(radius)))[..., None],
                       radiance, img)  # fmt: skip
    env = load_environment(str(write_test_exr(d / "discs.exr", img)), quiet=True)
    asset, _ = bake_env_sh(env, lights=2, light_shape="sphere",
                           provenance={"command_line": "test"})  # fmt: skip
    h5 = str(d / "discs.h5")
    write_asset(h5, asset)
    export_assets([h5], "webgl", str(d / "webgl"))
    return h5, str(d / "webgl")


def test_sphere_lights_pass(engine_browser, sphere_export, tmp_path):
    """shbakeSphereLambert (irradiance.glsl) and shbakeSphereTangent (tangent_irradiance.glsl)
    draw what the preview's twins do (:mod:`shbake.shading.sphere_light`), in the
    irradiance and both tangent passes; the same export with its radii zeroed (points) is
    far off in each, so the comparison sees the spheres."""
    h5, folder = sphere_export
    want = env_previews(h5)
    assert np.degrees(read_asset(h5)["/lights/angular_radius"]).min() > 5.0
    got = render(engine_browser, folder, ENV_JOBS)
    errors = {k: relative_rms(got[k], want[k]) for k in want}
    assert max(errors.values()) <= FLOAT_TOL, errors
    points = copy_export(folder, tmp_path / "points")
    path = os.path.join(points, "shbake.json")
    manifest = json.loads(open(path).read())
    manifest["uniforms"]["uLightRadius"]["value"] = [0.0] * SHBAKE_MAX_LIGHTS
    open(path, "w").write(json.dumps(manifest))
    got = render(engine_browser, points, ENV_JOBS)
    errors = {k: relative_rms(got[k], want[k]) for k in want}
    assert min(errors.values()) > 10 * FLOAT_TOL, errors


def half_bound(h5: str) -> float:
    """Relative RMS bound of the irradiance pass with half-float coefficients: each stored
    ``E_i`` moves by at most ``HALF_EPS |E_i|``, so a pixel's ``E/π`` by at most
    ``HALF_EPS Σ_i |E_i| |y_i(n)| / π`` (the lights stay float32 uniforms)."""
    asset = read_asset(h5)
    normals, _, mask = sphere_geometry(SIZE)
    c = np.asarray(asset["/irradiance/sh"])
    n = normals[mask]
    bound = HALF_EPS * (np.abs(real_sh(n, int(round(np.sqrt(len(c)))) - 1)) @ np.abs(c)) / np.pi
    want = preview(asset, "irradiance")[mask]
    return float(np.sqrt(np.sum(bound**2) / np.sum(want**2)))


def test_half_float_textures_within_their_bound(engine_browser, exported, tmp_path):
    """Half-float textures (RGBA16F KTX2, vkFormat 97, rounded from the export's float32,
    uploaded as ``HALF_FLOAT`` by the loader): the irradiance pass within
    :func:`half_bound`, the split-sum pass within ``2 HALF_EPS`` (a positive bilinear and
    α blend of values each off by ``HALF_EPS`` relative, times a DFG factor off by as much)."""
    env = copy_export(exported["env_dir"], tmp_path / "env")
    edit_texture(env, "uIrradiance", lambda t: t, half=True)
    split = copy_export(exported["splitsum_dir"], tmp_path / "split")
    for name in ("uLevels", "uDFG"):
        edit_texture(split, name, lambda t: t, half=True)
    assert read_ktx2(os.path.join(split, "uLevels.ktx2"))[0].dtype == np.float16
    e_err = relative_rms(render(engine_browser, env, ENV_JOBS[:1])["irradiance"],
                         env_previews(exported["env"])["irradiance"])  # fmt: skip
    got = render(engine_browser, split, glossy_jobs("splitsum"))
    want = glossy_previews(exported["splitsum"], "splitsum")
    s_err = max(relative_rms(got[k], want[k]) for k in want)
    assert e_err <= half_bound(exported["env"]), e_err
    assert s_err <= 2 * HALF_EPS, s_err


KTX2_FAULTS = {
    "not a KTX2 file": (0, b"\x00", "uIrradiance.ktx2: not a KTX2 file"),
    "RGB32F": (12, struct.pack("<I", 106), "uIrradiance.ktx2: vkFormat 106 (typeSize 4)"),
    "zstd": (44, struct.pack("<I", 2), "supercompressionScheme 2: not one uncompressed level"),
    "cube": (36, struct.pack("<I", 6), "faceCount 6: not a 2D texture or 2D array"),
    "short level": (88, struct.pack("<Q", 16), "uIrradiance.ktx2: level 0 (16 bytes at"),
    "array": (32, struct.pack("<I", 1), "1 layers, not the manifest's size"),
}
"""A byte patch of the export's ``uIrradiance.ktx2`` (offset, bytes) → the loader's error:
the identifier (§3.1), ``vkFormat`` 106 ``R32G32B32_SFLOAT``, Zstandard supercompression,
six faces, a level shorter than its texels, ``layerCount`` 1 (an array the manifest does not
declare)."""


@pytest.mark.parametrize("fault", sorted(KTX2_FAULTS))
def test_loader_refuses_other_ktx2(engine_browser, exported, tmp_path, fault):
    """Each KTX2 the loader does not read fails the load with an error naming the file."""
    offset, patch, message = KTX2_FAULTS[fault]
    folder = copy_export(exported["env_dir"], tmp_path / "x")
    path = os.path.join(folder, "uIrradiance.ktx2")
    data = bytearray(open(path, "rb").read())
    data[offset : offset + len(patch)] = patch
    open(path, "wb").write(data)
    with pytest.raises(RuntimeError, match=re.escape(message)):
        render(engine_browser, folder, ENV_JOBS[:1])


def test_viewer_opens_and_draws(engine_browser, exported, tmp_path):
    """index.html over HTTP: ready, no console error nor WebGL warning from the page, and a
    sphere of non-black pixels in the screenshot. Chromium's own notice ``GPU stall due to
    ReadPixels`` is not the page's: headless with ``--disable-gpu`` composites the canvas in
    software, reading it back (the viewer itself never reads pixels)."""
    import OpenImageIO as oiio

    for key in ("env_dir", "splitsum_dir", "shexp_dir", "shrm-surface_dir"):
        result = engine_browser.screenshot(os.path.join(exported[key], "index.html"), "canvas")
        own = [c for c in result["console"] if "GPU stall due to ReadPixels" not in c]
        assert result["state"] == "ready" and own == [], result["console"]
        png = tmp_path / f"{key}.png"
        png.write_bytes(result["png"])
        img = oiio.ImageBuf(str(png)).get_pixels(oiio.FLOAT)[..., :3]
        assert img.shape[:2] == (512, 512)  # the canvas element alone
        c = np.arange(512) + 0.5 - 256
        disc = np.hypot(c[:, None], c[None, :]) < 254  # the sphere, 2 pixels in from its rim
        assert np.all(img[disc].max(-1) > 0.0), np.count_nonzero(img[disc].max(-1) == 0)
        assert np.all(img[np.hypot(c[:, None], c[None, :]) > 258] == 0.0)  # black around


class TestExportCommand:
    """``shbake export --to webgl``: the folder, its bytes, refusals and the page's text."""

    @pytest.fixture
    def small(self, tmp_path):
        from tests.assets_examples import example, write_map

        out = {}
        for kind in ("env_sh", "splitsum_probe", "brdf_table"):
            out[kind] = str(tmp_path / f"{kind}.h5")
            write_asset(out[kind], example(kind, write_map(tmp_path / "map.exr")))
        return out

    def test_textures_are_ktx2(self, run_cli, small, tmp_path):
        """Every texture is a KTX 2.0 file as ktx-parse (the parser three.js vendors) reads
        it: RGBA32F (vkFormat 109, typeSize 4), the manifest's size, 2D (layerCount 0) or a
        2D array, one level, no supercompression, a Basic DFD (RGBSDA, BT.709, linear, four
        32-bit float|signed samples R, G, B, A, KDFS 1.3 §5.6); its texels are the asset's
        coefficients, split-sum levels and DFG table, as the spec reader
        (:func:`read_ktx2`) finds them."""
        from tests.helpers import run_node

        args = {"env_sh": [], "splitsum_probe": [], "brdf_table": ["--env", small["env_sh"]]}
        folders = {}
        for kind, extra in args.items():
            folders[kind] = tmp_path / kind
            code, _, err = run_cli("export", small[kind], "--to", "webgl", "-o", folders[kind],
                                   *extra)  # fmt: skip
            assert code == 0, err
            manifest = json.loads((folders[kind] / "shbake.json").read_text())
            assert not [n for n in os.listdir(folders[kind]) if n.endswith(".f32")]
            for name, t in manifest["textures"].items():
                assert t["file"] == name + ".ktx2"
                r = run_node("ktx2_read.mjs", str(folders[kind] / t["file"]))
                header = [r[k] for k in ("vkFormat", "typeSize", "pixelWidth", "pixelHeight",
                                         "pixelDepth", "layerCount", "faceCount", "levelCount",
                                         "supercompressionScheme")]  # fmt: skip
                assert header == [109, 4, t["width"], t["height"], 0, t.get("layers", 0), 1, 1, 0]
                dfd = ("colorModel", "colorPrimaries", "transferFunction", "bytesPlane0")
                assert [r[k] for k in dfd] == [1, 1, 1, 16]
                assert r["samples"] == [{"bitOffset": 32 * k, "bitLength": 31,
                                         "channelType": 0x80 | 0x40 | c}
                                        for k, c in enumerate((0, 1, 2, 15))]  # fmt: skip
                texels, _ = read_ktx2(str(folders[kind] / t["file"]))
                assert base64.b64decode(r["levels"][0]) == texels.tobytes()
        env = read_asset(small["env_sh"])
        irradiance = read_ktx2(str(folders["env_sh"] / "uIrradiance.ktx2"))[0].reshape(-1, 4)
        sh = np.asarray(env["/irradiance/sh"], dtype=np.float32)
        np.testing.assert_array_equal(irradiance[: len(sh), :3], sh)
        assert not irradiance[len(sh) :].any() and not irradiance[:, 3].any()
        probe = read_asset(small["splitsum_probe"])
        levels = read_ktx2(str(folders["splitsum_probe"] / "uLevels.ktx2"))[0]
        assert levels.shape[0] == int(probe.attrs["levels"])
        for k, layer in enumerate(levels):
            lv = np.asarray(probe[f"/levels/{k}"], dtype=np.float32)
            np.testing.assert_array_equal(layer[: lv.shape[0], : lv.shape[1], :3], lv)
        dfg = read_ktx2(str(folders["splitsum_probe"] / "uDFG.ktx2"))[0]
        np.testing.assert_array_equal(dfg[0, ..., :2], np.asarray(probe["/dfg"], np.float32))

    def test_same_inputs_same_bytes(self, run_cli, small, tmp_path):
        for kind in ("env_sh", "splitsum_probe"):
            folders = [tmp_path / f"{kind}{i}" for i in range(2)]
            for f in folders:
                code, _, err = run_cli("export", small[kind], "--to", "webgl", "-o", f)
                assert code == 0, err
            names = sorted(os.listdir(folders[0]))
            assert "index.html" in names and "shbake.json" in names
            for n in names:
                assert (folders[0] / n).read_bytes() == (folders[1] / n).read_bytes(), n

    @pytest.mark.parametrize("args, named", [(["--frame", "z-up"], "--frame"),
                                             (["--rotate", "30"], "--rotate")])  # fmt: skip
    def test_other_frames_refused(self, run_cli, small, tmp_path, args, named):
        code, _, err = run_cli("export", small["env_sh"], "--to", "webgl", "-o",
                               tmp_path / "out", *args)  # fmt: skip
        assert code == 1 and err.count("shbake: error:") == 1 and named in err, err
        assert not (tmp_path / "out").exists()

    @pytest.mark.parametrize("which", ["table without --env", "--env without a table"])
    def test_env_only_with_a_table(self, run_cli, small, tmp_path, which):
        table, env = small["brdf_table"], small["env_sh"]
        args = [table] if which.startswith("table") else [env, "--env", env]
        code, _, err = run_cli("export", *args, "--to", "webgl", "-o", tmp_path / "out")
        assert code == 1 and err.count("shbake: error:") == 1 and "--env" in err, err
        assert not (tmp_path / "out").exists()

    def test_asset_name_is_text_in_the_page(self, run_cli, small, tmp_path):
        from html.parser import HTMLParser

        hostile = tmp_path / "<img src=x onerror=alert(1)>&'\".h5"
        shutil.copy(small["env_sh"], hostile)
        code, _, err = run_cli("export", hostile, "--to", "webgl", "-o", tmp_path / "out")
        assert code == 0, err
        page = (tmp_path / "out" / "index.html").read_text()
        tags = []

        class Tags(HTMLParser):
            def handle_starttag(self, tag, attrs):
                tags.append(tag)

        Tags().feed(page)
        assert "img" not in tags and "<img" not in page
        assert "&lt;img src=x onerror=alert(1)&gt;&amp;" in page

    def test_export_again_replaces_the_folder(self, run_cli, small, tmp_path):
        """``-o`` naming an earlier export's folder: the new export replaces it whole (a
        split-sum export over an env_sh one keeps none of the env_sh files), no temporary."""
        out = tmp_path / "out"
        for kind in ("env_sh", "splitsum_probe"):
            code, _, err = run_cli("export", small[kind], "--to", "webgl", "-o", out)
            assert code == 0, err
        fresh = tmp_path / "fresh"
        assert run_cli("export", small["splitsum_probe"], "--to", "webgl", "-o", fresh)[0] == 0
        assert sorted(os.listdir(out)) == sorted(os.listdir(fresh))
        for n in os.listdir(fresh):
            assert (out / n).read_bytes() == (fresh / n).read_bytes(), n
        assert sorted(os.listdir(tmp_path)) == sorted(["fresh", "map.exr", "out", *map(
            os.path.basename, small.values())])  # fmt: skip

    @pytest.mark.parametrize("content", ["a user's file", "a subfolder", "a foreign manifest"])
    def test_other_folder_refused(self, run_cli, small, tmp_path, content):
        """An existing folder that is not an export is never replaced: one line, exit 1,
        the folder byte-identical."""
        from tests.faults import snapshot

        out = tmp_path / "out"
        out.mkdir()
        if content == "a user's file":
            (out / "notes.txt").write_text("keep me")
        elif content == "a subfolder":
            (out / "uIrradiance.ktx2").mkdir()
        else:
            (out / "shbake.json").write_text('{"format": "other"}')
        before = snapshot(tmp_path)
        code, _, err = run_cli("export", small["env_sh"], "--to", "webgl", "-o", out)
        assert code == 1 and err.count("shbake: error:") == 1 and "not replaced" in err, err
        assert snapshot(tmp_path) == before

    def test_input_inside_the_folder_refused(self, run_cli, small, tmp_path):
        """An input asset kept in the export's folder under an export file's name is not
        removed with the old folder: one line, exit 1, the folder byte-identical."""
        import shutil

        from tests.faults import snapshot

        out = tmp_path / "out"
        assert run_cli("export", small["env_sh"], "--to", "webgl", "-o", out)[0] == 0
        shutil.copy(small["env_sh"], out / "viewer.css")
        before = snapshot(tmp_path)
        code, _, err = run_cli("export", out / "viewer.css", "--to", "webgl", "-o", out)
        assert code == 1 and err.count("shbake: error:") == 1 and "holds the input" in err, err
        assert snapshot(tmp_path) == before

    def test_failed_export_keeps_the_old_folder(self, run_cli, small, tmp_path, monkeypatch):
        """A failure after the new files are staged (the page's template fails): the
        earlier export byte-identical, no staged folder or temporary left."""
        from shbake.errors import OutputError
        from shbake.format.exports import webgl
        from tests.faults import snapshot

        out = tmp_path / "out"
        assert run_cli("export", small["env_sh"], "--to", "webgl", "-o", out)[0] == 0
        before = snapshot(tmp_path)

        def broken(title):
            raise OutputError("no space left on device")

        monkeypatch.setattr(webgl, "viewer_page", broken)
        code, _, err = run_cli("export", small["splitsum_probe"], "--to", "webgl", "-o", out)
        assert code == 1 and err.count("shbake: error:") == 1, err
        assert snapshot(tmp_path) == before

    def test_stale_staged_folder_removed(self, run_cli, small, tmp_path):
        """A staged folder left by a killed run (its process gone) goes with the next run."""
        stale = tmp_path / ".out.shbake-2147483646-1.tmp"
        stale.mkdir()
        (stale / "uIrradiance.ktx2").write_bytes(b"\0" * 16)
        assert run_cli("export", small["env_sh"], "--to", "webgl", "-o", tmp_path / "out")[0] == 0
        assert not stale.exists()
