"""shbake's exports rendered by the engines themselves (headless Chromium, WebGL2 on SwiftShader).

Each engine page (``tests/engines/pages/``) loads the export with the snippet of
``docs/EXPORTS.md`` (checked verbatim here), draws a unit sphere into a float render
target with tone mapping and output encoding off from three views, and once more with a
material writing the normal it drew (``tests/engines/harness.mjs``,
``tests/engine_browser.py``). The references are brute force on the original map, never
the export's own math:

* diffuse: a white Lambert sphere shows ``E(n)/π``; ``E`` from shbake's asset (SH + sun)
  at the rendered normal, within 2 % (max relative);
* glossy: metal (F0 1) and dielectric (F0 0.04, black base) spheres at roughness 0, 0.3
  and 0.6 against the brute-force GGX prefiltered radiance ``P(R', α)``
  (:func:`shbake.reference.prefiltered.reference_radiance`) at the direction and
  roughness the engine looks up, times the engine's environment-BRDF factor measured by
  rendering the same sphere in a white environment (see :func:`three_expected`):
  within 5 % median and 15 % at the 95th percentile (luminance);
* orientation: of the 48 axis flips and swaps applied to the mirror lookup, the identity
  fits the rendered mirror best, by a margin, in every view.

A face flipped in the file, roughness levels mis-mapped and gamma applied twice each
make the glossy comparison fail. ``@pytest.mark.slow``: the six shared maps, and the
mis-mapped levels (the one fault that bakes a chain anew, 6-11 s an engine; the fault tests
that reuse the chain stay in ``make test``).
"""

import os

import numpy as np
import pytest

from shbake.bakers.env_sh import bake_env_sh
from shbake.batch.export import export_assets
from shbake.envmap import load_environment
from shbake.format.asset import write_asset
from shbake.format.exports.source import load_source
from tests.engine_browser import inner_pixels, quad_derivatives
from tests.engine_cases import (
    BABYLON_CUBES,
    DIFFUSE_TOL,
    FAST_MAPS,
    FILAMENT_CUBES,
    FILAMENT_MIN_ROUGHNESS,
    FOV_DEG,
    LAMBERT,
    SIZE,
    THREE_CUBES,
    VIEWS,
    against_expected,
    assert_identity_wins,
    babylon_expected,
    busiest_face,
    chain_sizes,
    diffuse_error,
    export_recording,
    filament_cubes,
    filament_expected,
    glossy_errors,
    glossy_within,
    pick_pixels,
    print_errors,
    render_babylon,
    render_filament,
    render_maps,
    render_three_glossy,
    snippet,
    sphere_materials,
    three_expected,
    upside_down,
    white_env,
    white_environment,
    white_ktx1,
)
from tests.helpers import ROOT, map_path

REBAKED_FAULT = pytest.param("roughness-mapping", marks=pytest.mark.slow, id="roughness-mapping")
"""Levels baked at glTF-IBL-Sampler's even spacing: a second chain, so ``make test-all``."""

RENDER_SAMPLES = 256
"""GGX samples per texel of the chains ``make test`` renders (:data:`FAST_MAPS`; the exports'
default is 512). Half the bake; on forest every material's median and p95 moved by at most
0.7 points from 512's (three.js mirror p95 7.3 → 8.0 %, Filament r 0.3 p95 2.8 → 3.2 %), far
inside 5 % / 15 %."""


def rendered(cubes: dict, name: str) -> dict:
    """``cubes`` as map ``name`` is rendered: with :data:`RENDER_SAMPLES` in ``make test``; the
    six-map study (``make test-all``) at the exports' default, whose figures
    docs/BENCHMARKS.md records."""
    return {**cubes, "samples": RENDER_SAMPLES} if name in FAST_MAPS else cubes


pytestmark = pytest.mark.xdist_group("engine-render")
"""One worker runs this module (``make test``: ``--dist loadgroup``), so each map's chains
are baked once and one browser serves every page."""


@pytest.fixture(scope="module", params=render_maps())
def baked(request, tmp_path_factory):
    """An env_sh asset (lmax 2) of a shared map."""
    name = request.param
    path = str(map_path(name))
    d = tmp_path_factory.mktemp(f"render-{name}")
    env = load_environment(path, quiet=True)
    asset, _ = bake_env_sh(env, lmax=2, provenance={"input_abspath": os.path.abspath(path)})
    h5 = str(d / f"{name}.h5")
    write_asset(h5, asset)
    return {"name": name, "env": env, "h5": h5, "dir": d}


class TestHarness:
    """The camera the Python side assumes is the one the page rendered with."""

    def test_rendered_normals_are_the_ray_sphere_normals(self, engine_browser, baked):
        exported = export_assets([baked["h5"]], "threejs", str(baked["dir"] / "cam.json"))
        r = engine_browser.render("three.html", VIEWS, SIZE, FOV_DEG,
                                  probe=engine_browser.url(exported[0]), materials=[])  # fmt: skip
        inner = inner_pixels(r["normal"])
        assert inner.sum() > 0.6 * len(VIEWS) * SIZE * SIZE * np.pi / 4 * 0.9
        for k, view in enumerate(VIEWS):
            eye = np.asarray(view.eye)
            d = r["rays"][k][inner[k]]
            b = d @ eye
            t = -b - np.sqrt(b * b - (eye @ eye - 1.0))
            hit = eye + t[:, None] * d
            n = r["normal"][k][inner[k]][:, :3]
            n /= np.linalg.norm(n, axis=-1, keepdims=True)
            worst = np.degrees(np.arccos(np.clip((hit * n).sum(-1), -1.0, 1.0))).max()
            assert worst < 2.0, (k, worst)  # tessellation and pixel-centre offsets only

    def test_quad_derivatives_are_the_gpus(self, engine_browser, baked):
        """:func:`quad_derivatives` of the rendered normal (turned into view space) give the
        geometry roughness three's page computed with the GPU's own ``dFdx``/``dFdy`` (the
        normal pass's alpha − 1): the derivative rule the Filament reference relies on."""
        r = engine_browser.render("three.html", VIEWS, SIZE, FOV_DEG, materials=[])
        inner = inner_pixels(r["normal"])
        world = r["normal"][..., :3].astype(np.float64)
        world /= np.maximum(np.linalg.norm(world, axis=-1, keepdims=True), 1e-30)
        view = np.empty_like(world)
        for k, v in enumerate(VIEWS):
            back = np.asarray(v.eye, dtype=np.float64) - np.asarray(v.target)
            back /= np.linalg.norm(back)
            right = np.cross(v.up, back)
            right /= np.linalg.norm(right)
            view[k] = world[k] @ np.stack([right, np.cross(back, right), back]).T
        dx, dy = quad_derivatives(view)
        ours = np.maximum(np.abs(dx), np.abs(dy)).max(-1)[inner]
        gpu = r["normal"][..., 3][inner] - 1.0
        print(f"\ngeometry roughness: GPU median {np.median(gpu):.4f}, "
              f"|ours - GPU| median {np.median(np.abs(ours - gpu)):.2e}")  # fmt: skip
        assert np.median(np.abs(ours - gpu)) < 0.05 * np.median(gpu)


class TestThree:
    """three.js r187: ``LightProbe`` (diffuse) and the prefiltered PMREM cube (glossy)."""

    @pytest.fixture(scope="class")
    @classmethod
    def three(cls, baked, engine_browser):
        out = str(baked["dir"] / "t_pmrem.ktx2")
        pmrem, chain = export_recording(baked["h5"], "threejs-pmrem", out,
                                        **rendered(THREE_CUBES, baked["name"]))
        files = [export_assets([baked["h5"]], "threejs", str(baked["dir"] / "t.json"))[0], pmrem[0]]
        white = white_environment(baked["dir"], chain_sizes(THREE_CUBES))
        renders = render_three_glossy(engine_browser, files[1], white)
        pick = pick_pixels(renders["env"]["normal"])
        return {"files": files, "white": white, "renders": renders, "pick": pick, "chain": chain,
                "expected": three_expected(baked["env"], renders, pick)}  # fmt: skip

    def test_snippet_is_the_documented_one(self):
        page = snippet(os.path.join(ROOT, "tests", "engines", "pages", "three.mjs"), "three.js")
        doc = open(os.path.join(ROOT, "docs", "EXPORTS.md"), encoding="utf-8").read()
        assert page in doc

    def test_diffuse_probe(self, engine_browser, baked, three):
        r = engine_browser.render(
            "three.html",
            VIEWS,
            SIZE,
            FOV_DEG,
            probe=engine_browser.url(three["files"][0]),
            materials=[{"name": "lambert", "kind": "lambert", "color": [1.0, 1.0, 1.0]}],
        )
        err = diffuse_error(r, load_source(baked["h5"]), clamped=False)
        print(f"\n{baked['name']}: three.js diffuse (LightProbe) max relative error {err:.2e}")
        assert err < DIFFUSE_TOL
        assert not [c for c in r["console"] if c.startswith(("error", "pageerror"))]

    def test_environment_brdf_is_three_s(self, baked, three):
        """The white environment renders the DFG factors as :func:`three_scattering` reads them
        from three's table (so the glossy reference matches three's term, not a guess)."""
        errors = glossy_errors(three_expected(None, three["renders"], three["pick"], white=True))
        print(f"\n{baked['name']}: three.js white furnace {errors}")
        # grazing pixels: screen derivatives (geometry roughness) are estimated here
        assert all(med < 0.01 and p95 < 0.08 for med, p95 in errors.values()), errors

    def test_glossy(self, baked, three):
        errors = glossy_errors(three["expected"])
        print_errors("three.js", baked["name"], errors)
        assert glossy_within(errors), errors

    def test_report_reads_the_chain_as_three_does(self, baked, three):
        """``export --report`` measures the chain as
        :func:`shbake.format.exports.cube_chain.read_chain` reads it; put in the place of
        brute force, that read of the baked chain is what three.js draws from the file."""
        expected = three_expected(None, three["renders"], three["pick"],
                                  chain=three["chain"]["levels"])  # fmt: skip
        errors = glossy_errors(expected)
        print_errors("three.js vs read_chain", baked["name"], errors)
        assert all(med < 0.005 and p95 < 0.02 for med, p95 in errors.values()), errors

    def test_orientation(self, baked, three):
        """The mirror's lookup direction fits the rendered mirror best unturned, in every view."""
        renders = three["renders"]
        # F0 1: single + multi scattering
        assert_identity_wins(baked, renders["env"], renders["white"]["radiance"]["metal0.0"])

    @pytest.mark.parametrize("fault", ["flip-face", REBAKED_FAULT, "gamma"])
    def test_a_fault_fails(self, engine_browser, baked, three, fault, monkeypatch):
        """A face flipped in the file, levels baked at other roughnesses (glTF-IBL-Sampler's
        even spacing) and radiance gamma-encoded once more each break the glossy match."""
        from shbake.format.exports import ktx2

        out = str(baked["dir"] / f"fault-{fault}_pmrem.ktx2")
        if fault == "roughness-mapping":  # baked anew (256², fewer samples: the fault dominates)
            monkeypatch.setattr("shbake.batch.export.FIXED_LOD_MAPPING", ("filament",))
            files = export_assets([baked["h5"]], "threejs-pmrem", out, mapping="gltf-ibl-sampler",
                                  **{**THREE_CUBES, "size": 256, "samples": 128})  # fmt: skip
        else:  # the chain already baked, faulted as the file is written
            real = ktx2.write_cube_chain
            chain = three["chain"]
            busiest = busiest_face(chain["levels"][0])

            def faulty(path, src, levels, roughness, mapping, note=""):
                levels = [lv.copy() for lv in levels]
                for lv in levels:
                    if fault == "flip-face":
                        upside_down(lv, busiest)
                    else:
                        lv[:] = lv ** (1 / 2.2)  # gamma-encoded: the engine decodes nothing
                real(path, src, levels, roughness, mapping, note)

            monkeypatch.setattr("shbake.format.exports.three_pmrem.write_cube_chain", faulty)
            monkeypatch.setattr(
                "shbake.batch.export.prefilter_chain",
                lambda *a, **k: (chain["levels"], chain["roughness"]),
            )
            files = export_assets([baked["h5"]], "threejs-pmrem", out,
                                  **rendered(THREE_CUBES, baked["name"]))
        render = engine_browser.render(
            "three.html", VIEWS, SIZE, FOV_DEG, pmrem=engine_browser.url(files[0]),
            materials=sphere_materials(("metal",)),
        )  # fmt: skip
        errors = glossy_errors(against_expected(three["expected"], render, three["pick"]))
        print(f"\nthree.js with fault {fault}: {errors}")
        assert not glossy_within(errors)


class TestBabylon:
    """Babylon.js 9.31: ``--to babylon`` as a ``.env`` and as a ``.gltf`` (same chain)."""

    @pytest.fixture(scope="class")
    @classmethod
    def babylon(cls, baked, engine_browser):
        cubes = rendered(BABYLON_CUBES, baked["name"])
        files, chain = export_recording(baked["h5"], "babylon", str(baked["dir"] / "b.env"),
                                        **cubes)  # fmt: skip
        env_file = files[0]
        gltf_file = export_recording(baked["h5"], "babylon", str(baked["dir"] / "b.gltf"),
                                     chain=chain, **cubes)[0][0]  # fmt: skip
        materials = [LAMBERT, *sphere_materials()]
        renders = {
            "env": render_babylon(engine_browser, materials, env=env_file),
            "gltf": render_babylon(engine_browser, materials, gltf=gltf_file),
            "white": render_babylon(engine_browser, sphere_materials(),
                                    env=white_env(baked["dir"], BABYLON_CUBES["size"])),
        }  # fmt: skip
        pick = pick_pixels(renders["env"]["normal"])
        src = load_source(baked["h5"])
        # the same spheres and views in both files: brute force computed once
        from_env = babylon_expected(baked["env"], src, renders["env"], renders["white"], pick)
        expected = {"env": from_env, "gltf": against_expected(from_env, renders["gltf"], pick)}
        return {"env": env_file, "gltf": gltf_file, "renders": renders, "pick": pick,
                "chain": chain, "src": src, "expected": expected}  # fmt: skip

    def test_snippet_is_the_documented_one(self):
        page = snippet(os.path.join(ROOT, "tests", "engines", "pages", "babylon.mjs"), "Babylon.js")
        doc = open(os.path.join(ROOT, "docs", "EXPORTS.md"), encoding="utf-8").read()
        assert page in doc

    @pytest.mark.parametrize("path", ["env", "gltf"])
    def test_diffuse(self, baked, babylon, path):
        render = babylon["renders"][path]
        err = diffuse_error(render, babylon["src"])
        print(f"\n{baked['name']}: Babylon.js diffuse ({path}) max relative error {err:.2e}")
        assert err < DIFFUSE_TOL
        assert not [c for c in render["console"] if c.startswith(("error: BJS", "pageerror"))]

    @pytest.mark.parametrize("path", ["env", "gltf"])
    def test_glossy(self, baked, babylon, path):
        errors = glossy_errors(babylon["expected"][path])
        print_errors(f"Babylon.js ({path})", baked["name"], errors)
        assert glossy_within(errors), errors

    def test_orientation(self, baked, babylon):
        """The mirror's lookup direction fits the rendered mirror best unturned, in every view."""
        r = babylon["renders"]
        assert_identity_wins(baked, r["env"], r["white"]["radiance"]["metal0.0"])

    @pytest.mark.parametrize("fault", ["flip-face", REBAKED_FAULT, "gamma"])
    def test_a_fault_fails(self, engine_browser, baked, babylon, fault):
        """A face flipped in the file, levels baked at glTF-IBL-Sampler's even spacing and
        the texture left in ``gammaSpace`` (Babylon's default: radiance decoded twice) each
        break the glossy match."""
        chain = babylon["chain"]
        levels = [lv.copy() for lv in chain["levels"]]
        out, files, mapping = str(baked["dir"] / f"fault-{fault}.gltf"), {}, "babylon"
        if fault == "flip-face":
            busiest = busiest_face(levels[0])
            for lv in levels:
                upside_down(lv, busiest)
        elif fault == "roughness-mapping":  # baked anew (fewer samples: the fault dominates)
            mapping = "gltf-ibl-sampler"
            levels = None
        else:
            files["gammaSpace"] = True
        if levels is None:
            cubes = {**BABYLON_CUBES, "size": 256, "samples": 128}  # the fault dominates
            files["gltf"] = export_assets([baked["h5"]], "babylon", out, mapping=mapping, **cubes)[
                0
            ]
        else:
            faulty = {"levels": levels, "roughness": chain["roughness"]}
            cubes = rendered(BABYLON_CUBES, baked["name"])  # the chain is the fixture's
            files["gltf"] = export_recording(baked["h5"], "babylon", out, chain=faulty,
                                             **cubes)[0][0]  # fmt: skip
        render = render_babylon(engine_browser, sphere_materials(("metal",)), **files)
        errors = glossy_errors(against_expected(babylon["expected"]["gltf"], render,
                                                babylon["pick"]))  # fmt: skip
        print(f"\nBabylon.js with fault {fault}: {errors}")
        assert not glossy_within(errors)


class TestFilament:
    """Filament 1.53.4 (web): ``--to filament`` with its own chain (:func:`filament_cubes`:
    :data:`FILAMENT_CUBES`, ten levels on studio)."""

    @pytest.fixture(scope="class")
    @classmethod
    def filament(cls, baked, engine_browser):
        cubes = rendered(filament_cubes(baked["name"]), baked["name"])
        files, chain = export_recording(baked["h5"], "filament", str(baked["dir"] / "f_sh.txt"),
                                        **cubes)  # fmt: skip
        ibl = next(f for f in files if f.endswith("_ibl.ktx"))
        renders = {
            "env": render_filament(
                engine_browser, baked["dir"], [LAMBERT, *sphere_materials()], ibl
            ),
            "white": render_filament(engine_browser, baked["dir"], sphere_materials(),
                                     white_ktx1(baked["dir"], chain_sizes(cubes))),
        }  # fmt: skip
        pick = pick_pixels(renders["env"]["normal"])
        return {"files": files, "ibl": ibl, "renders": renders, "chain": chain, "pick": pick,
                "cubes": cubes,
                "expected": filament_expected(baked["env"], renders["env"], renders["white"],
                                              pick)}  # fmt: skip

    def test_snippet_is_the_documented_one(self):
        page = snippet(os.path.join(ROOT, "tests", "engines", "pages", "filament.mjs"), "Filament")
        doc = open(os.path.join(ROOT, "docs", "EXPORTS.md"), encoding="utf-8").read()
        assert page in doc

    def test_diffuse(self, baked, filament):
        """The light built by the snippet shades the KTX's SH (Filament's own
        ``createIblFromKtx1`` would light diffuse from the reflections instead)."""
        render = filament["renders"]["env"]
        err = diffuse_error(render, load_source(baked["h5"]))
        print(f"\n{baked['name']}: Filament diffuse max relative error {err:.2e}")
        assert err < DIFFUSE_TOL
        assert not [c for c in render["console"]
                    if c.startswith("pageerror") or "not an expected" in c]  # fmt: skip

    def test_glossy(self, baked, filament):
        errors = glossy_errors(filament["expected"])
        print_errors("Filament", baked["name"], errors)
        assert glossy_within(errors), errors

    def test_orientation(self, baked, filament):
        """The mirror's lookup direction fits the rendered mirror best unturned, in every view."""
        r = filament["renders"]
        scale = r["white"]["radiance"]["metal0.0"]
        assert_identity_wins(baked, r["env"], scale, FILAMENT_MIN_ROUGHNESS**2)

    @pytest.mark.parametrize("fault", ["flip-face", "unmirrored", REBAKED_FAULT, "gamma"])
    def test_a_fault_fails(self, engine_browser, baked, filament, fault, monkeypatch):
        """A face flipped in the file, the cube in shbake's (three.js's) orientation instead of
        Filament's, levels baked at glTF-IBL-Sampler's even spacing, and radiance
        gamma-encoded once more each break the glossy match."""
        from shbake.format.exports import filament as fil

        chain = filament["chain"]
        out = str(baked["dir"] / f"fault-{fault}_sh.txt")
        if fault == "roughness-mapping":  # baked anew (256², fewer samples: the fault dominates)
            monkeypatch.setattr("shbake.batch.export.FIXED_LOD_MAPPING", ("threejs-pmrem",))
            files = export_assets([baked["h5"]], "filament", out, mapping="gltf-ibl-sampler",
                                  **{**FILAMENT_CUBES, "size": 256, "samples": 128})  # fmt: skip
        else:
            faces = fil.filament_faces
            if fault == "flip-face":
                busiest = busiest_face(faces(chain["levels"][0]))

                def faulty(level):
                    level = faces(level).copy()
                    upside_down(level, busiest)
                    return level
            elif fault == "unmirrored":

                def faulty(level):
                    return np.asarray(level)
            else:

                def faulty(level):
                    return faces(level) ** (1 / 2.2)  # gamma-encoded: the engine decodes nothing

            monkeypatch.setattr(fil, "filament_faces", faulty)
            files, _ = export_recording(baked["h5"], "filament", out, chain=chain,
                                        **filament["cubes"])  # fmt: skip
        ibl = next(f for f in files if f.endswith("_ibl.ktx"))
        render = render_filament(engine_browser, baked["dir"], sphere_materials(("metal",)), ibl)
        errors = glossy_errors(against_expected(filament["expected"], render, filament["pick"]))
        print(f"\nFilament with fault {fault}: {errors}")
        assert not glossy_within(errors)
