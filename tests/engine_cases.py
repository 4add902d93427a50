"""The engine render cases shared by tests/system/test_engine_render.py and bench/engine_render.py:
the views, materials and cube chains, how each engine page is rendered, and the brute-force
references and error measures the renders are compared with (that test module's docstring),
and the bound no chain read by an engine's blend beats (:func:`blend_bound`,
bench/engine_blend_floor.py)."""

import functools
import json
import os
import re

import numpy as np
import pytest
from scipy.optimize import linprog

from shbake.batch.export import export_assets
from shbake.conventions import REC709_LUMINANCE, ggx_alpha
from shbake.format.exports import filament, three_pmrem
from shbake.format.exports.cube_chain import (
    BABYLON_MIN_ALPHA,
    level_of_roughness,
    read_chain,
    roughness_of_level,
)
from shbake.format.exports.gltf import png_rgba8
from shbake.format.exports.ktx2 import write_ktx2
from shbake.format.exports.source import shbake_irradiance
from shbake.reference.irradiance import brute_force_irradiance
from shbake.reference.prefiltered import reference_radiance
from shbake.sh.basis import real_sh
from tests.engine_browser import (
    View,
    inner_pixels,
    latlong_bilinear,
    quad_derivatives,
    reflect,
    signed_permutations,
    write_sphere_gltf,
)
from tests.helpers import ROOT, SHARED_MAPS

SIZE = 128
"""Render-target edge (pixels): the sphere spans about 124 of them."""

FOV_DEG = 30.0

VIEWS = [View((0.0, 0.0, 4.0)), View((3.0, 2.0, -2.0)), View((-2.0, -3.0, 2.0))]

GLOSSY = [(f"{kind}{r}", kind, r) for r in (0.0, 0.3, 0.6) for kind in ("metal", "dielectric")]
"""(name, kind, perceptual roughness): metal = white base, metalness 1 (F0 1);
dielectric = black base, metalness 0 (F0 0.04, no diffuse)."""

REFERENCE_PIXELS = 1500
"""Sphere pixels (all views together) the brute-force references are computed at."""

THREE_CUBES = {"size": 512, "floor": 4, "samples": 512}
"""three.js's chain in the tests (``--size 512 --floor 4``, docs/EXPORTS.md): 512² to 4²,
eight levels."""

FILAMENT_CUBES = {"size": 512, "floor": 8, "samples": 512}
"""Filament's chain in the tests (``--size 512 --floor 8``, docs/EXPORTS.md): 512² to 8², seven
levels."""

FILAMENT_DEEP_CUBES = {"size": 1024, "floor": 2, "samples": 512}
"""Filament's chain for a map whose lamps span a few of its texels (``--size 1024 --floor 2``,
docs/EXPORTS.md): 1024² to 2², ten levels. Filament reads a chain at ``lod = (n − 1) r (2 −
r)`` (``iblRoughnessOneLevel = levelCount − 1``), so only more levels bring the lobes its
blend mixes nearer each other; its "mirror" (its floor 0.089 widened by gltfio's specular
anti-aliasing, :data:`FILAMENT_SPECULAR_AA`) reads the two levels after the first. On
studio, no seven-level chain can render every roughness from that floor to 0.3 within 15 %
at more than 68 % of the mirror's directions (``bench/engine_blend_floor.py``,
``tests/system/test_engine_blend_bound.py``): the seven-level chain rendered its mirror at
5.0 / 30.6 %, nine levels (1024² → 4²) at 2.7 / 17.4 %, ten at 2.0 / 15.0 % (docs/BENCHMARKS.md
"Ten levels for Filament on studio")."""

FILAMENT_DEEP_MAPS = ("studio",)
"""The shared maps Filament's tests render with :data:`FILAMENT_DEEP_CUBES` (the one whose
seven-level bound exceeds 15 % at more than 5 % of the mirror's directions)."""


def filament_cubes(name: str) -> dict:
    """Filament's chain in the tests for map ``name``."""
    return FILAMENT_DEEP_CUBES if name in FILAMENT_DEEP_MAPS else FILAMENT_CUBES


def busiest_face(level: np.ndarray) -> int:
    """The face of a cube level ``(6, n, n, 3)`` whose luminance varies most (the face a
    fault test turns upside down: a flipped face of dark, even sky changes little)."""
    return int(np.argmax((np.asarray(level)[..., :3] @ REC709_LUMINANCE).std(axis=(1, 2))))


def upside_down(level: np.ndarray, face: int) -> None:
    """Turn ``face`` of a cube level upside down in place (a fault the tests must catch)."""
    level[face] = level[face, ::-1]


def chain_sizes(cubes: dict) -> list[int]:
    """The face edges of a chain ``{"size", "floor"}``, level 0 first."""
    return [cubes["size"] >> i for i in range((cubes["size"] // cubes["floor"]).bit_length())]


FAST_MAPS = ("forest",)
"""The map ``make test`` renders; the six shared maps are ``slow`` (and bench/engine_render.py)."""

DIFFUSE_TOL = 0.02

MEDIAN_TOL, P95_TOL = 0.05, 0.15


def render_maps():
    return [
        pytest.param(m, marks=() if m in FAST_MAPS else pytest.mark.slow, id=m) for m in SHARED_MAPS
    ]


def luminance_error(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    y = REC709_LUMINANCE
    return np.abs(got @ y - want @ y) / np.maximum(want @ y, 1e-12)


def snippet(path: str, marker: str) -> str:
    """The text between ``BEGIN snippet MARKER`` and ``END snippet MARKER`` lines of ``path``."""
    text = open(path, encoding="utf-8").read()
    m = re.search(rf"// BEGIN snippet {re.escape(marker)}\n(.*?)// END snippet {re.escape(marker)}",
                  text, re.S)  # fmt: skip
    assert m, f"{path}: no snippet {marker}"
    return m.group(1)


def white_environment(d, sizes: list[int]) -> str:
    """A test-side PMREM KTX2 of a unit-radiance environment (every texel 1)."""
    pmrem = str(d / "white_pmrem.ktx2")
    write_ktx2(pmrem, [np.ones((6, s, s, 4)) for s in sizes], cube=True)
    return pmrem


THREE_DFG = os.path.join(ROOT, "tests", "engines", "node_modules", "three", "src", "renderers",
                         "shaders", "DFGLUTData.js")  # fmt: skip


def three_dfg(roughness: np.ndarray, n_dot_v: np.ndarray) -> np.ndarray:
    """three's DFG table (``DFGLUTData.js``: 16×16 RG16F, u = roughness, v = n·v, linear
    filtering, rows from v = 0) read as the shader does (``lights_fragment_begin``:
    ``texture2D(dfgLUT, vec2(roughness, dotNV))``): ``(…, 2)`` = (scale, bias)."""
    text = open(THREE_DFG, encoding="utf-8").read()
    words = re.findall(r"0x[0-9a-f]{4}", text.split("new Uint16Array", 1)[1].split("]", 1)[0])
    lut = np.array([int(w, 16) for w in words], dtype="<u2").view("<f2").astype(np.float64)
    lut = lut.reshape(16, 16, 2)

    def axis(t):
        x = np.clip(np.asarray(t) * 16 - 0.5, 0.0, 15.0)
        i0 = np.minimum(np.floor(x).astype(int), 14)
        return i0, (x - i0)[..., None]

    c0, fc = axis(roughness)
    r0, fr = axis(n_dot_v)
    top = (1 - fc) * lut[r0, c0] + fc * lut[r0, c0 + 1]
    bottom = (1 - fc) * lut[r0 + 1, c0] + fc * lut[r0 + 1, c0 + 1]
    return (1 - fr) * top + fr * bottom


def three_scattering(f0: float, roughness: np.ndarray, n_dot_v: np.ndarray) -> tuple:
    """``(FssEss, Fms·Ems)`` of three's ``computeMultiscattering`` (Fdez-Agüera 2019) for a
    grey ``F0`` and ``F90 = 1``."""
    fab = three_dfg(roughness, n_dot_v)
    fss_ess = f0 * fab[..., 0] + fab[..., 1]
    ess = fab[..., 0] + fab[..., 1]
    ems = 1.0 - ess
    favg = f0 + (1.0 - f0) / 21.0
    fms = fss_ess * favg / (1.0 - ems * favg)
    return fss_ess, fms * ems


def sphere_materials(kinds=("metal", "dielectric")):
    """The :data:`GLOSSY` spheres of ``kinds`` as page materials (the fault tests draw the
    metals only: a fault breaks both kinds alike)."""
    out = []
    for name, kind, r in GLOSSY:
        if kind not in kinds:
            continue
        metal = kind == "metal"
        out.append({"name": name, "kind": "standard", "color": [1.0 if metal else 0.0] * 3,
                    "metalness": 1.0 if metal else 0.0, "roughness": r})  # fmt: skip
    return out


def render_three_glossy(browser, pmrem: str, white: str) -> dict:
    """The glossy spheres in the export's environment and in the white one."""
    kw = {"size": SIZE, "fov_deg": FOV_DEG, "materials": sphere_materials()}
    return {
        "env": browser.render("three.html", VIEWS, pmrem=browser.url(pmrem), **kw),
        "white": browser.render("three.html", VIEWS, pmrem=browser.url(white), **kw),
    }


THREE_MIN_ROUGHNESS = three_pmrem.MIN_ROUGHNESS


def three_expected(env, renders: dict, pick, white: bool = False, chain=None) -> dict:
    """Per glossy material: (rendered, expected) radiance at the ``pick``ed sphere pixels.

    three r187 shades an environment-lit surface (``RE_IndirectSpecular_Physical``) as
    ``FssEss · prefiltered(R', r) + Fms·Ems · E(n)/π``, ``E`` the irradiance it reads
    from the PMREM (``getIBLIrradiance``): ``r`` the material's roughness raised to
    :data:`THREE_MIN_ROUGHNESS` plus the geometry roughness (``getGeometryRoughness``: the
    view-space normal's screen derivatives, which the page's normal pass writes as
    ``alpha − 1`` with the GPU's own ``dFdx``/``dFdy``), ``R' = normalize(mix(R, n, r⁴))``
    (``envmap_physical_pars_fragment``), the two factors from three's DFG table
    (:func:`three_scattering`). The expected value puts the brute-force ``P(R', r²)`` and
    brute-force ``E(n)`` in their place; ``white=True``: a unit environment (both 1);
    ``chain`` (the export's levels): three's reads of them instead, as
    :func:`shbake.format.exports.cube_chain.read_chain` emulates them (``P``: at
    ``roughnessToMip(r) = (n − 1) r (2 − r)``; ``E/π``: at the last level, ``getIBLIrradiance``).
    """
    normal = renders["env"]["normal"]
    n = normal[..., :3][pick]
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    rays = renders["env"]["rays"][pick]
    n_dot_v = np.clip(-(rays * n).sum(-1), 0.0, 1.0)
    r_geo = normal[..., 3][pick] - 1.0
    refl = reflect(rays, n)
    if chain is not None:
        top = len(chain) - 1
        e_over_pi = read_chain(chain, n, top)
    elif not white:
        d, w, rad = env.samples()
        e_over_pi = brute_force_irradiance(d, w, rad, n) / np.pi

    @functools.cache
    def prefiltered(r):  # metal and dielectric of one roughness: the same lobe
        r_eff = np.minimum(np.maximum(r, THREE_MIN_ROUGHNESS) + r_geo, 1.0)
        look = refl + (n - refl) * (r_eff**4)[:, None]
        look /= np.linalg.norm(look, axis=-1, keepdims=True)
        if chain is not None:
            return read_chain(chain, look, top * r_eff * (2.0 - r_eff))
        return reference_radiance(env, look, r_eff**2)

    out = {}
    for name, kind, r in GLOSSY:
        if name not in renders["white" if white else "env"]["radiance"]:
            continue
        r_eff = np.minimum(np.maximum(r, THREE_MIN_ROUGHNESS) + r_geo, 1.0)
        single, multi = three_scattering(1.0 if kind == "metal" else 0.04, r_eff, n_dot_v)
        if white:
            want = (single + multi)[:, None] * np.ones(3)
        else:
            want = single[:, None] * prefiltered(r) + multi[:, None] * e_over_pi
        got = renders["white" if white else "env"]["radiance"][name][..., :3][pick]
        out[name] = (got, want)
    return out


def pick_pixels(normal: np.ndarray) -> tuple:
    """A fixed sample of :data:`REFERENCE_PIXELS` inner sphere pixels (all views)."""
    idx = np.argwhere(inner_pixels(normal))
    rng = np.random.default_rng(0)
    idx = idx[np.sort(rng.choice(len(idx), min(REFERENCE_PIXELS, len(idx)), replace=False))]
    return tuple(idx.T)


def against_expected(expected: dict, render: dict, pick) -> dict:
    """``expected`` (per material: (rendered, expected)) with the rendered values taken from
    another ``render`` of the same spheres and views (a fault test's: the same pixels, so
    the same brute force, computed once)."""
    return {name: (render["radiance"][name][..., :3][pick], want)
            for name, (_, want) in expected.items() if name in render["radiance"]}  # fmt: skip


def glossy_errors(expected: dict) -> dict:
    """Per material: (median, 95th percentile) of the luminance relative error."""
    out = {}
    for name, (got, want) in expected.items():
        e = luminance_error(got, want)
        out[name] = (float(np.median(e)), float(np.percentile(e, 95)))
    return out


def glossy_within(errors: dict) -> bool:
    """Every material within :data:`MEDIAN_TOL` (median) and :data:`P95_TOL` (95th
    percentile)."""
    return all(m <= MEDIAN_TOL and p <= P95_TOL for m, p in errors.values())


def print_errors(engine: str, name: str, errors: dict) -> None:
    for material, (med, p95) in errors.items():
        print(f"\n{name}: {engine} {material}: median {med:.2%}, p95 {p95:.2%}", end="")


ORIENTATION_MARGIN = 0.75
"""The identity's median error, at most this fraction of the best other orientation's."""

ORIENTATION_PIXELS = 100
"""Sphere pixels per view the orientation fit uses when its reference is brute force (48
orientations × 3 views of brute-force ``P``: the cost of Filament's orientation test)."""


def assert_identity_wins(baked, render: dict, scale: np.ndarray, alpha: float = 0.0) -> None:
    """Of the 48 axis flips and swaps applied to the mirror's lookup direction, the identity
    fits the rendered mirror (``metal0.0`` divided by its environment-BRDF ``scale``, the
    same sphere in a unit environment) best by :data:`ORIENTATION_MARGIN`, in every view.

    The mirror's reference is the map read bilinearly, or, for an engine whose "mirror" is a
    lobe of GGX width ``alpha`` (Filament's roughness floor), brute-force ``P(R, alpha)``
    at :data:`ORIENTATION_PIXELS` pixels per view (on studio the map read bilinearly fits
    Filament's blurred lamps in every orientation alike: identity 0.91, next 0.94; forest
    0.26 → 0.09 against next 0.59 → 0.49 at 250 pixels; brute force at 100 pixels: identity
    0.06, next 0.43–0.49 in the three views)."""
    normal = render["normal"]
    inner = inner_pixels(normal)
    got_all = render["radiance"]["metal0.0"][..., :3]
    rng = np.random.default_rng(0)
    for k in range(len(VIEWS)):
        n = normal[k][inner[k]][:, :3]
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        refl = reflect(render["rays"][k][inner[k]], n)
        got = got_all[k][inner[k]] / scale[k][inner[k]][:, :3]
        if alpha > 0.0:
            keep = np.sort(rng.choice(len(n), min(ORIENTATION_PIXELS, len(n)), replace=False))
            refl, got = refl[keep], got[keep]

            def lookup(d):
                return reference_radiance(baked["env"], d, alpha)
        else:

            def lookup(d):
                return latlong_bilinear(baked["env"].pixels, d)

        medians = [
            float(np.median(luminance_error(got, lookup(refl @ m.T))))
            for m in signed_permutations()
        ]
        best_other = min(medians[1:])
        print(f"\n{baked['name']} view {k}: identity {medians[0]:.3f}, next {best_other:.3f}")
        assert medians[0] < ORIENTATION_MARGIN * best_other


def export_recording(h5: str, target: str, out: str, chain: dict | None = None, **kw) -> tuple:
    """``export_assets`` for one file, the chain it baked kept (``chain`` given: that chain
    written instead of baking one): (files, chain)."""
    import shbake.batch.export as batch

    kept, bake = dict(chain or {}), batch.prefilter_chain

    def recording(*args, **kwargs):
        if not kept:
            kept["levels"], kept["roughness"] = bake(*args, **kwargs)
        return kept["levels"], kept["roughness"]

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(batch, "prefilter_chain", recording)
        return export_assets([h5], target, out, **kw), kept


BABYLON_CUBES = {"size": 512, "floor": 2, "samples": 512}
"""Babylon.js's chain in the tests (``--size 512 --floor 2``, docs/EXPORTS.md): 512² to 2²,
nine levels."""


def white_env(d, size: int) -> str:
    """A test-side Babylon ``.env`` of a unit-radiance environment: every RGBD texel
    (255, 255, 255, 255) = 1 on every level to 1², and the polynomial of ``E/π = 1``
    (``xx = yy = zz = 1``, since ``n_x² + n_y² + n_z² = 1``), read with level scale 1."""
    images, position, mipmaps = [], 0, []
    n = size
    while n >= 1:
        png = png_rgba8(np.full((n, n, 4), 255, np.uint8))
        for _ in range(6):
            images.append(png)
            mipmaps.append({"length": len(png), "position": position})
            position += len(png)
        n //= 2
    one, zero = [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]
    manifest = {
        "version": 2, "width": size, "imageType": "image/png",
        "irradiance": {k: one if k in ("xx", "yy", "zz") else zero
                       for k in ("x", "y", "z", "xx", "yy", "zz", "yz", "zx", "xy")},
        "specular": {"mipmaps": mipmaps, "lodGenerationScale": 1.0},
    }  # fmt: skip
    path = str(d / "white.env")
    magic = bytes([0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36])
    with open(path, "wb") as f:
        f.write(magic + json.dumps(manifest).encode() + b"\0" + b"".join(images))
    return path


def babylon_expected(env, src, renders: dict, white: dict, pick) -> dict:
    """Per glossy material: (rendered, expected) radiance at the ``pick``ed sphere pixels.

    Babylon.js 9 shades an environment-lit PBR surface (``pbrBlockReflection``) with the
    radiance ``mix(prefiltered(R, α), E(n)/π, α)`` (``MIX_IBL_RADIANCE_WITH_IRRADIANCE``,
    on by default; ``E`` its SH irradiance), ``α = r² + 0.0005`` (``pbrHelperFunctions``
    ``convertRoughnessToAverageSlope``), ``R = reflect(−v, n)``, times its environment BRDF
    (DFG table, energy conservation), a factor of ``n·v`` and ``r`` only: measured per pixel
    by the same sphere in a unit environment (``white``: both terms 1). The expected value
    puts brute-force ``P(R, α)`` and the asset's ``E`` (which the diffuse test checks
    Babylon shades) in their place; the mirror (``α`` 0.0005, narrower than the sub-texels
    brute force sums) reads the map bilinearly, the limit that sum tends to.
    """
    normal = renders["normal"]
    n = normal[..., :3][pick]
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    refl = reflect(renders["rays"][pick], n)
    e_over_pi = shbake_irradiance(src, n) / np.pi

    @functools.cache
    def prefiltered(a):  # metal and dielectric of one roughness: the same lobe
        if a == BABYLON_MIN_ALPHA:
            return latlong_bilinear(env.pixels, refl)
        return reference_radiance(env, refl, a)

    out = {}
    for name, _kind, r in GLOSSY:
        if name not in renders["radiance"]:
            continue
        a = r * r + BABYLON_MIN_ALPHA
        factor = white["radiance"][name][..., :3][pick]
        want = factor * ((1.0 - a) * prefiltered(a) + a * e_over_pi)
        out[name] = (renders["radiance"][name][..., :3][pick], want)
    return out


LAMBERT = {"name": "lambert", "kind": "lambert", "color": [1.0, 1.0, 1.0], "metalness": 0.0,
           "roughness": 1.0}  # fmt: skip
"""A white diffuse sphere (Babylon: a PBR dielectric with no specular lobe, F0 factor 0)."""


def diffuse_error(render: dict, src, clamped: bool = True) -> float:
    """Max relative error of the rendered white Lambert sphere against ``E(n)/π`` of the asset.

    Per direction ``max |engine − shbake| / Σ_i |E_i y_i(n)|/π`` (the size of the terms
    summed, as ``tests/export_checks.py``: ``E(n)`` itself nears 0 where they cancel, studio).
    ``clamped``: the engine shows no negative light where the SH truncation makes ``E < 0``
    (Filament ``light_indirect.fs`` ``Irradiance_SphericalHarmonics`` ``max(…, 0)``; Babylon
    ``pbrBlockFinalColorComposition.js:45`` ``max(finalColor, 0)``), so shbake's is clamped
    too; three.js (``clamped=False``) shows it as it is.
    """
    inner = inner_pixels(render["normal"])
    n = render["normal"][..., :3][inner]
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    want = shbake_irradiance(src, n) / np.pi
    if clamped:
        want = np.maximum(want, 0.0)
    terms = np.abs(real_sh(n, 2)) @ np.abs(src.irradiance9) / np.pi
    if src.sun_direction is not None:
        terms += np.maximum(n @ src.sun_direction, 0.0)[:, None] * src.sun_irradiance / np.pi
    got = render["radiance"]["lambert"][..., :3][inner]
    return float((np.abs(got - want) / terms).max(-1).max())


def render_babylon(browser, materials, **files) -> dict:
    """The sphere with ``materials`` in the environment of ``files`` (``env=`` a .env,
    ``gltf=`` a .gltf, loaded by the snippet), plus ``gammaSpace`` for the fault test."""
    params = {k: browser.url(v) if k in ("env", "gltf") else v for k, v in files.items()}
    return browser.render("babylon.html", VIEWS, SIZE, FOV_DEG, materials=materials, **params)


FILAMENT_MIN_ROUGHNESS = filament.MIN_ROUGHNESS

FILAMENT_SPECULAR_AA = (0.15, 0.2)
"""``specularAntiAliasingVariance`` and ``…Threshold`` of gltfio's materials
(``libs/gltfio/materials/base.mat.in``: ``specularAntiAliasing : true``, Filament's
defaults): ``normalFiltering`` (``shaders/src/surface_shading_parameters``…
``getRoughnessPixelParams``) raises ``α²`` by ``min(2 · 0.15 (|∂x n|² + |∂y n|²), 0.2)`` of
the world geometric normal before the roughness floor."""


def white_ktx1(d, sizes: list[int]) -> str:
    """A test-side Filament IBL of a unit-radiance environment: KTX 1.1, R11F_G11F_B10F texels
    1.0 (R, G: exponent 15 mantissa 0 = 0x3C0; B 0x1E0) on every level, ``sh`` metadata of
    ``E/π = 1`` (the first coefficient 1)."""
    import struct

    texel = 0x3C0 | (0x3C0 << 11) | (0x1E0 << 22)
    entry = b"sh\0" + ("1 1 1\n" + "0 0 0\n" * 8).encode() + b"\0"
    kvd = struct.pack("<I", len(entry)) + entry + b"\0" * (-len(entry) % 4)
    head = bytes.fromhex("ab4b5458203131bb0d0a1a0a") + struct.pack(
        "<13I", 0x04030201, 0x8C3A, 1, 0x1907, 0x8C3A, 0x1907, sizes[0], sizes[0], 0, 0, 6,
        len(sizes), len(kvd))  # fmt: skip
    body = b"".join(struct.pack("<I", n * n * 4) + struct.pack("<I", texel) * (6 * n * n)
                    for n in sizes)  # fmt: skip
    path = str(d / "white_ibl.ktx")
    with open(path, "wb") as f:
        f.write(head + kvd + body)
    return path


def filament_expected(env, renders: dict, white: dict, pick) -> dict:
    """Per glossy material: (rendered, expected) radiance at the ``pick``ed sphere pixels.

    Filament (``shaders/src/light_indirect.fs``) shades ``specularDFG · prefilteredRadiance(R′,
    r) · energyCompensation`` with ``r`` widened by its specular anti-aliasing
    (:data:`FILAMENT_SPECULAR_AA`, the rendered normal's :func:`quad_derivatives`) and
    raised to :data:`FILAMENT_MIN_ROUGHNESS`, ``α = r²`` and ``R′ = mix(R, n, α²)``
    (``getSpecularDominantDirection``); the factors depend on ``n·v`` and ``r`` only and are
    measured per pixel in a unit environment (``white``). The expected value puts brute-force
    ``P(R′, α)`` in its place.
    """
    unit = renders["normal"][..., :3]
    unit = unit / np.maximum(np.linalg.norm(unit, axis=-1, keepdims=True), 1e-30)
    du, dv = quad_derivatives(unit)
    variance, threshold = FILAMENT_SPECULAR_AA
    kernel = np.minimum(2.0 * variance * ((du * du).sum(-1) + (dv * dv).sum(-1)), threshold)[pick]
    n = unit[pick]
    refl = reflect(renders["rays"][pick], n)

    @functools.cache
    def prefiltered(r):  # metal and dielectric of one roughness: the same lobe
        filtered = np.minimum(r**4 + kernel, 1.0) ** 0.25
        a = np.maximum(filtered, FILAMENT_MIN_ROUGHNESS) ** 2
        look = refl + (n - refl) * (a * a)[:, None]
        look /= np.linalg.norm(look, axis=-1, keepdims=True)
        return reference_radiance(env, look, a)

    out = {}
    for name, _kind, r in GLOSSY:
        if name not in renders["radiance"]:
            continue
        want = white["radiance"][name][..., :3][pick] * prefiltered(r)
        out[name] = (renders["radiance"][name][..., :3][pick], want)
    return out


def render_filament(browser, d, materials, ibl: str) -> dict:
    """The sphere with ``materials`` in the Filament IBL ``ibl`` (loaded by the snippet)."""
    spheres = {k: browser.url(write_sphere_gltf(str(d / f"sphere_{k}.gltf"), k))
               for k in ("lit", "diffuse", "normal")}  # fmt: skip
    return browser.render("filament.html", VIEWS, SIZE, FOV_DEG, materials=materials,
                          ibl=browser.url(ibl), spheres=spheres)  # fmt: skip


BOUND_LODS_PER_LEVEL = 12
"""Lods per level a blend bound (:func:`blend_bound`) is sampled at."""


def bound_lods(floor: float, levels: int, up_to: float) -> tuple[np.ndarray, np.ndarray]:
    """``(lods, knots)``: the lods a chain of ``levels`` is read at (``(n − 1) r (2 − r)``,
    three.js and Filament) by materials from roughness ``floor`` (the engine's) to ``up_to``,
    :data:`BOUND_LODS_PER_LEVEL` per level, and the levels whose blends cover them."""
    lo, hi = (level_of_roughness(r, levels, "filament") for r in (floor, up_to))
    lods = np.linspace(lo, hi, int(np.ceil((hi - lo) * BOUND_LODS_PER_LEVEL)) + 1)
    return lods, np.arange(int(np.floor(lo)), int(np.ceil(hi)) + 1)


def prefiltered_luminance(env, look: np.ndarray, lods: np.ndarray, levels: int) -> np.ndarray:
    """Brute-force ``P(d, α(lod))`` luminance at directions ``look``, ``(len(look), len(lods))``,
    floored at 1e-12 of its largest value."""
    target = np.stack([
        reference_radiance(env, look, ggx_alpha(roughness_of_level(lod, levels, "filament")))
        @ REC709_LUMINANCE
        for lod in lods
    ], axis=1)  # fmt: skip
    return np.maximum(target, 1e-12 * target.max())


def blend_bound(lods: np.ndarray, knots: np.ndarray, target: np.ndarray) -> float:
    """The least largest relative error over ``lods`` that any chain read by a linear blend of
    its levels ``knots`` can have where the lobe is ``target`` (``(len(lods),)``, positive).

    Whatever the levels hold, the read at ``lod`` is ``Σ_k h_k(lod) v_k`` (``h_k``: the
    blend's hat weights, ``v_k``: what level ``k`` gives there): the linear program
    ``min e`` subject to ``|Σ_k h_k(lod_i) v_k − t_i| ≤ e t_i``, ``v_k ≥ 0`` (HiGHS). With
    the levels free per direction and no texels, every real chain errs at least this much
    at that direction for some lod of the range (``bench/engine_blend_floor.py``)."""
    hats = np.maximum(0.0, 1.0 - np.abs(lods[:, None] - knots[None]))
    scaled = hats / target[:, None]
    ones = np.ones((len(target), 1))
    a_ub = np.vstack([np.hstack([scaled, -ones]), np.hstack([-scaled, -ones])])
    b_ub = np.concatenate([np.ones(len(target)), -np.ones(len(target))])
    cost = np.zeros(len(knots) + 1)
    cost[-1] = 1.0
    return float(linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=(0, None), method="highs").x[-1])
