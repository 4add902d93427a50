"""Engine exports checked in the engines' own code under node (tests/engines, ``npm ci``).

Babylon.js's glTF loader and three.js's ObjectLoader/LightProbe evaluate the
exported files; their irradiance must equal shbake's (SH + lights) at 300
directions on every shared map, plain, with ``--extract-sun`` and with ``--lights auto``
(several fitted lights). Each test
of a convention has a twin proving that the comparison fails for a flipped
axis or a π factor.
"""

import base64
import glob
import json
import os
import shutil

import numpy as np
import pytest

from shbake.bakers.env_sh import bake_env_sh
from shbake.batch.export import export_assets
from shbake.conventions import REC709_LUMINANCE
from shbake.envmap import load_environment
from shbake.evaluation.env_sh import brute_force_reference
from shbake.format.asset import write_asset
from shbake.format.exports import target_module
from shbake.format.exports.source import frame_matrix, load_source, shbake_irradiance
from shbake.sh.windows import fibonacci_sphere
from tests.helpers import run_node

SHARED = os.environ.get(
    "SHBAKE_SHARED", os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared")
)
MAPS = sorted(glob.glob(os.path.join(SHARED, "hdri", "*.exr")))
N_DIRS = 300
TOL = 1e-4
SMALL = {
    "size": 16,
    "floor": 4,
    "samples": 32,
}  # specular chain kept small: these tests are about SH

pytestmark = pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")


def _scale(src, dirs) -> np.ndarray:
    """Per direction and channel, ``Σ_i |E_i y_i(n)|`` (+ the sun term): the size of what is summed.

    Relative errors are taken against it rather than ``|E(n)|`` alone, which
    nears 0 where the SH terms cancel (three.js's constants have 6 digits,
    e.g. ``0.886227``, so its absolute error is ~1e-6 of the terms).
    """
    from shbake.sh.basis import real_sh

    s = np.abs(real_sh(dirs, 2)[..., :, None] * src.irradiance9[None]).sum(axis=-2)
    for direction, irradiance in src.lights:
        s = s + np.maximum(dirs @ direction, 0.0)[:, None] * irradiance
    return s


def _rel(got: np.ndarray, want: np.ndarray, src=None, dirs=None) -> float:
    """Largest per-direction ``‖got − want‖∞ / ‖scale‖∞`` (scale: :func:`_scale`, or ``want``)."""
    num = np.abs(got - want).max(axis=-1)
    ref = _scale(src, dirs) if src is not None else want
    den = np.maximum(np.abs(ref).max(axis=-1), 1e-12)
    return float((num / den).max())


@pytest.fixture(scope="module")
def dirs_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("dirs") / "dirs.json"
    p.write_text(json.dumps(fibonacci_sphere(N_DIRS).tolist()))
    return str(p)


@pytest.fixture(
    scope="module",
    params=[(m, s) for m in MAPS for s in ("", "sun", "lights")],
    ids=lambda p: f"{os.path.basename(p[0])[:-4]}{'-' + p[1] if p[1] else ''}",
)
def baked(request, tmp_path_factory):
    """An env_sh asset of a shared map (lmax 2): plain, with the sun extracted or with
    ``--lights auto``; and its exports."""
    path, mode = request.param
    sun = mode == "sun"
    d = tmp_path_factory.mktemp("exp")
    env = load_environment(path, quiet=True)
    asset, _ = bake_env_sh(
        env, lmax=2, sun=sun, lights="auto" if mode == "lights" else None,
        provenance={"input_abspath": os.path.abspath(path)},
    )  # fmt: skip
    h5 = str(d / "a.h5")
    write_asset(h5, asset)
    gltf = export_assets([h5], "gltf", str(d / "a.gltf"), **SMALL)[0]
    three = export_assets([h5], "threejs", str(d / "a.json"))[0]
    name = os.path.basename(path)[:-4] + ("-" + mode if mode else "")
    return {"h5": h5, "gltf": gltf, "three": three, "env": env, "sun": sun, "dir": d, "name": name}


class TestBabylonGltf:
    """gltf.write: Babylon.js's loader reads shbake's irradiance (sun included)."""

    def test_irradiance_equals_shbake(self, baked, dirs_file):
        r = run_node("babylon_irradiance.mjs", baked["gltf"], dirs_file)
        got = np.array(r["irradiance"])
        src = load_source(baked["h5"])
        d = np.array(json.load(open(dirs_file)))
        want = shbake_irradiance(src, d)
        assert r["lights"] == len(src.lights)
        print(
            f"\n{baked['name']}: Babylon vs shbake {_rel(got, want, src, d):.2e} "
            f"(per-direction |E|: {_rel(got, want):.2e})"
        )
        assert _rel(got, want, src, d) < TOL

    def test_validator_reports_no_error(self, baked):
        r = run_node("validate_gltf.mjs", baked["gltf"])
        assert r["numErrors"] == 0, r["messages"]

    def test_right_handed_babylon_scene(self, baked, dirs_file, tmp_path):
        """scene.useRightHandedSystem: the export made for it matches; the default one does not."""
        src = load_source(baked["h5"])
        d = np.array(json.load(open(dirs_file)))
        want = shbake_irradiance(src, d)
        rh = export_assets(
            [baked["h5"]], "gltf", str(tmp_path / "rh.gltf"), babylon_scene="right-handed", **SMALL
        )[0]
        got = np.array(run_node("babylon_irradiance.mjs", rh, dirs_file, "rh")["irradiance"])
        assert _rel(got, want, src, d) < TOL
        lh = np.array(
            run_node("babylon_irradiance.mjs", baked["gltf"], dirs_file, "rh")["irradiance"]
        )
        assert _rel(lh, want) > 1e-3

    @pytest.mark.parametrize("fault", ["flip-x", "flip-y", "flip-z", "pi", "no-sign"])
    def test_a_wrong_convention_fails(self, baked, dirs_file, fault):
        """The comparison is sensitive: a mirrored axis, a π or Babylon's sign ignored fails."""
        doc = json.load(open(baked["gltf"]))
        light = doc["extensions"]["EXT_lights_image_based"]["lights"][0]
        c = np.array(light["irradianceCoefficients"])
        odd = {"flip-x": [3, 4, 7], "flip-y": [1, 4, 5], "flip-z": [2, 5, 7]}
        if fault in odd:
            c[odd[fault]] *= -1
        elif fault == "pi":
            c *= np.pi
        else:
            c *= np.array([1, -1, 1, 1, -1, -1, 1, 1, 1])[:, None]
        light["irradianceCoefficients"] = c.tolist()
        bad = str(baked["dir"] / "bad.gltf")
        with open(bad, "w") as f:
            json.dump(doc, f)
        for png in glob.glob(str(baked["dir"] / "a_specular_*.png")):
            shutil.copy(png, png.replace("a_specular_", "bad_specular_"))
        for im in doc["images"]:
            im["uri"] = im["uri"].replace("a_specular_", "bad_specular_")
        with open(bad, "w") as f:
            json.dump(doc, f)
        got = np.array(run_node("babylon_irradiance.mjs", bad, dirs_file)["irradiance"])
        want = shbake_irradiance(load_source(baked["h5"]), np.array(json.load(open(dirs_file))))
        assert _rel(got, want) > 1e-3


class TestThreejs:
    """threejs.write: three's ObjectLoader + LightProbe.getIrradianceAt + DirectionalLight."""

    def test_irradiance_equals_shbake(self, baked, dirs_file):
        r = run_node("three_irradiance.mjs", baked["three"], dirs_file)
        got = np.array(r["irradiance"])
        src = load_source(baked["h5"])
        d = np.array(json.load(open(dirs_file)))
        want = shbake_irradiance(src, d)
        assert r["probes"] == 1 and r["lights"] == 3 * len(src.lights)
        print(
            f"\n{baked['name']}: three vs shbake {_rel(got, want, src, d):.2e} "
            f"(per-direction |E|: {_rel(got, want):.2e})"
        )
        assert _rel(got, want, src, d) < TOL

    @pytest.mark.parametrize(
        ("frame", "rotate", "want"),
        [("y-up", 0.0, [1.5, 2.0, -3.0]), ("z-up", 90.0, [1.5, 3.0, 2.0])],
    )
    def test_probe_position_reaches_three(self, sky_asset, dirs_file, frame, rotate, want):
        import shutil

        import h5py

        h5 = str(sky_asset["dir"] / f"pos-{frame}.h5")
        shutil.copy(sky_asset["h5"], h5)
        with h5py.File(h5, "r+") as f:
            f.attrs["probe_position"] = np.array([1.5, 2.0, -3.0])
        out = str(sky_asset["dir"] / f"pos-{frame}.json")
        export_assets([h5], "threejs", out, frame=frame, rotate_deg=rotate)
        r = run_node("three_irradiance.mjs", out, dirs_file)
        # z-up: (x, y, z) -> (x, -z, y); --rotate turns the environment, not the probe
        assert r["positions"] == [want]
        src = load_source(h5, frame=frame, rotate_deg=rotate)
        want_e = shbake_irradiance(src, np.array(json.load(open(dirs_file))))
        assert _rel(np.array(r["irradiance"]), want_e) < TOL  # the sun does not move with it
        unity = json.load(open(export_assets([h5], "unity", out[:-5] + ".unity.json",
                                             frame=frame, rotate_deg=rotate)[0]))  # fmt: skip
        assert unity["position"] == [-want[0], want[1], want[2]]  # Unity: x mirrored

    @pytest.mark.parametrize("fault", ["irradiance-sh", "flip-x", "pi"])
    def test_a_wrong_convention_fails(self, baked, dirs_file, fault):
        doc = json.load(open(baked["three"]))
        probe = doc["object"]["children"][0]
        c = np.array(probe["sh"]).reshape(9, 3)
        if fault == "irradiance-sh":  # the cosine kernel applied twice
            c *= np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)[:, None]
        elif fault == "flip-x":
            c[[3, 4, 7]] *= -1
        else:
            c /= np.pi
        probe["sh"] = c.reshape(-1).tolist()
        bad = str(baked["dir"] / "bad.json")
        with open(bad, "w") as f:
            json.dump(doc, f)
        got = np.array(run_node("three_irradiance.mjs", bad, dirs_file)["irradiance"])
        want = shbake_irradiance(load_source(baked["h5"]), np.array(json.load(open(dirs_file))))
        assert _rel(got, want) > 1e-3


class TestAgainstBruteForce:
    """Engine irradiance vs brute-force quadrature of the original map (reported)."""

    def test_report(self, baked, dirs_file):
        ref = brute_force_reference(baked["env"], n_dirs=N_DIRS)
        got = np.array(run_node("three_irradiance.mjs", baked["three"], dirs_file)["irradiance"])
        y = got @ REC709_LUMINANCE
        rel = np.abs(y - ref["irradiance"]) / np.maximum(ref["irradiance"], 1e-30)
        print(
            f"\n{baked['name']}: engine vs brute force "
            f"luminance mean {rel.mean():.3%} max {rel.max():.3%}"
        )
        assert np.all(np.isfinite(rel))


class TestFrameRoundTrip:
    """--frame z-up --rotate θ: the engine's E at R d equals shbake's world E at d."""

    @pytest.mark.parametrize("frame,deg", [("z-up", 30.0), ("y-up", -75.0)])
    def test_three_and_babylon(self, baked, dirs_file, tmp_path, frame, deg):
        R = frame_matrix(frame, deg)
        d = np.array(json.load(open(dirs_file)))
        dt = tmp_path / "dt.json"
        dt.write_text(json.dumps((d @ R.T).tolist()))
        src = load_source(baked["h5"])
        want = shbake_irradiance(src, d)  # world frame
        three = export_assets(
            [baked["h5"]], "threejs", str(tmp_path / "t.json"), frame=frame, rotate_deg=deg
        )[0]
        got = np.array(run_node("three_irradiance.mjs", three, str(dt))["irradiance"])
        assert _rel(got, want, src, d) < TOL
        # and the rotation is really applied: reading the rotated export in the world frame fails
        got_world = np.array(run_node("three_irradiance.mjs", three, dirs_file)["irradiance"])
        assert _rel(got_world, want) > 1e-3


class TestRegistry:
    """target_module: every target name resolves; unknown names are refused."""

    def test_targets(self):
        assert target_module("babylon").CUBES is target_module("gltf").CUBES
        with pytest.raises(Exception, match="unknown export target"):
            target_module("unreal")


def _ktx2(path: str) -> dict:
    return run_node("ktx2_read.mjs", path)


class TestKtx2:
    """ktx2.write: read by ktx-parse (three.js's KTX2 parser); level 0 = the mirror cube."""

    @pytest.fixture(scope="class")
    @classmethod
    def written(cls, tmp_path_factory):
        d = tmp_path_factory.mktemp("ktx")
        path = os.path.join(SHARED, "hdri", "esplanade.exr")
        env = load_environment(path, quiet=True)
        asset, _ = bake_env_sh(env, lmax=2, provenance={"input_abspath": os.path.abspath(path)})
        h5 = str(d / "e.h5")
        write_asset(h5, asset)
        files = export_assets(
            [h5],
            "ktx2",
            str(d / "e.ktx2"),
            frame="z-up",
            rotate_deg=20.0,
            size=16,
            floor=1,
            samples=32,
        )
        return {"files": files, "env": env}

    def test_header_and_mip_chain(self, written):
        r = _ktx2(written["files"][0])
        assert (r["vkFormat"], r["typeSize"], r["faceCount"], r["supercompressionScheme"]) == (
            97,
            2,
            6,
            0,
        )
        assert r["pixelWidth"] == 16 and r["levelCount"] == 5  # 16, 8, 4, 2, 1
        assert [len(base64.b64decode(b)) for b in r["levels"]] == [
            6 * n * n * 8 for n in (16, 8, 4, 2, 1)
        ]
        assert r["colorModel"] == 1 and r["transferFunction"] == 1
        assert json.loads(r["keyValue"]["shbake.roughness"])[0] == 0.0

    def test_level0_is_the_mirror_cube(self, written):
        from shbake.bakers.cube_prefilter import downsample_cube, mirror_cube

        r = _ktx2(written["files"][0])
        lv0 = np.frombuffer(base64.b64decode(r["levels"][0]), "<f2").reshape(6, 16, 16, 4)
        want = mirror_cube(written["env"], 32, rotation=frame_matrix("z-up", 20.0))
        want = downsample_cube(want)  # the chain's level 0 is the 2x source box-filtered
        np.testing.assert_allclose(lv0[..., :3], want, rtol=1e-3, atol=1e-6)  # half-float rounding
        assert np.all(lv0[..., 3] == 1.0)

    def test_dfg_table(self, written):
        from shbake.bakers.dfg import dfg_table

        r = _ktx2(written["files"][1])
        assert (r["vkFormat"], r["faceCount"], r["levelCount"]) == (83, 1, 1)
        t = np.frombuffer(base64.b64decode(r["levels"][0]), "<f2").reshape(
            r["pixelHeight"], r["pixelWidth"], 2
        )
        np.testing.assert_allclose(t, np.transpose(dfg_table(), (1, 0, 2)), rtol=2e-3, atol=1e-4)


def _fireflies(img: np.ndarray) -> np.ndarray:
    """Texels brighter (luminance) than 4× the median of their 3×3 neighbourhood (within a face)."""
    y = img @ REC709_LUMINANCE
    f, n, _ = y.shape
    pad = np.pad(y, ((0, 0), (1, 1), (1, 1)), mode="edge")
    win = np.stack([pad[:, i : i + n, j : j + n] for i in range(3) for j in range(3)], -1)
    return y > 4.0 * np.median(win, axis=-1)


class TestFireflies:
    """prefilter_level with filtered importance sampling: no speck the converged reference lacks."""

    @pytest.fixture(scope="class")
    @classmethod
    def sunny(cls):
        from shbake.bakers.cube_prefilter import cube_pyramid, mirror_cube

        env = load_environment(os.path.join(SHARED, "hdri", "esplanade.exr"), quiet=True)
        return env, cube_pyramid(mirror_cube(env, 64))

    @pytest.mark.parametrize("alpha", [0.2, 0.3, 0.4])
    def test_no_new_fireflies(self, sunny, alpha):
        from shbake.bakers.cube_prefilter import prefilter_level, reference_level

        env, pyr = sunny
        ref = reference_level(env, 32, alpha)
        fis = prefilter_level(pyr, 32, alpha, samples=256)
        plain = prefilter_level(pyr, 32, alpha, samples=256, fis=False)
        new_fis = _fireflies(fis) & ~_fireflies(ref)
        new_plain = _fireflies(plain) & ~_fireflies(ref)
        print(
            f"\nalpha {alpha}: fireflies FIS {int(new_fis.sum())}, "
            f"point sampling {int(new_plain.sum())}"
        )
        assert new_fis.sum() == 0
        assert new_plain.sum() > 0  # the test can fail: plain importance sampling shows specks

    def test_faces_meet_without_seam(self, sunny):
        """Texels either side of a cube edge differ no more than neighbours inside a face."""
        from shbake.bakers.cube_prefilter import cube_directions, prefilter_level

        _, pyr = sunny
        img = prefilter_level(pyr, 16, 0.3, samples=128)
        d, _ = cube_directions(16)
        flat, y = d.reshape(-1, 3), (img @ REC709_LUMINANCE).reshape(-1)
        face = np.repeat(np.arange(6), 256)
        cos = flat @ flat.T
        np.fill_diagonal(cos, -1)
        nb = np.argmax(cos, axis=1)
        jump = np.abs(np.log(y / y[nb]))
        across = face != face[nb]
        assert jump[across].max() <= 1.5 * jump[~across].max()


def _poly(d: np.ndarray) -> np.ndarray:
    """The 9 polynomials Filament's ``irradianceSH`` and Unity's ``SHEvalLinearL0L1/L2`` sum."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    one = np.ones_like(x)
    return np.stack([one, y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y], -1)


@pytest.fixture(scope="module")
def sky_asset(tmp_path_factory):
    d = tmp_path_factory.mktemp("eng")
    path = os.path.join(SHARED, "hdri", "esplanade.exr")
    env = load_environment(path, quiet=True)
    asset, _ = bake_env_sh(
        env, lmax=2, sun=True, provenance={"input_abspath": os.path.abspath(path)}
    )
    h5 = str(d / "s.h5")
    write_asset(h5, asset)
    return {"h5": h5, "dir": d, "env": env}


class TestFilament:
    """filament.write: cmgen's sh.txt / KTX ``sh`` metadata read by Filament's ``irradianceSH``.

    Not Filament's own code (no CPU build of it runs here): the shader's polynomial
    (``irradianceSH``, quoted in the module docstring) evaluated on the parsed text.
    """

    @staticmethod
    def _parse_sh_txt(path: str) -> np.ndarray:
        rows = []
        for line in open(path):
            inner = line.split("(", 1)[1].split(")", 1)[0]
            rows.append([float(v) for v in inner.split(",")])
        return np.array(rows)

    def test_sh_txt_gives_e_over_pi(self, sky_asset):
        out = str(sky_asset["dir"] / "f_sh.txt")
        files = export_assets([sky_asset["h5"]], "filament", out, size=8, floor=1, samples=16)
        sh = self._parse_sh_txt(files[0])
        d = fibonacci_sphere(N_DIRS)
        src = load_source(sky_asset["h5"])
        from shbake.sh.basis import real_sh

        want = real_sh(d, 2) @ src.irradiance9 / np.pi
        got = _poly(d) @ sh
        assert np.abs(got - want).max() < 1e-12 * np.abs(want).max() + 1e-14
        assert np.abs(_poly(d * [-1, 1, 1]) @ sh - want).max() > 1e-3 * np.abs(want).max()
        assert np.abs(np.pi * got - want).max() > 1e-3 * np.abs(want).max()
        assert any(f.endswith("_sun.json") for f in files)

    def test_ktx1_metadata_and_levels(self, sky_asset):
        """A KTX 1.1 reader written from the spec (§2) and GL's packed-float rule reads back
        the sh, cmgen's R11F_G11F_B10F header and the mirror level in Filament's orientation
        (mirrored in x: Filament samples world d at GL d)."""
        import struct

        from shbake.bakers.cube_prefilter import cube_directions, cube_pyramid, mirror_cube

        out = str(sky_asset["dir"] / "k_sh.txt")
        export_assets([sky_asset["h5"]], "filament", out, size=8, floor=1, samples=16)
        data = open(str(sky_asset["dir"] / "k_skybox.ktx"), "rb").read()
        assert data[:12] == bytes.fromhex("ab4b5458203131bb0d0a1a0a")
        h = struct.unpack_from("<13I", data, 12)
        assert h[0] == 0x04030201 and (h[1], h[3], h[4], h[5]) == (0x8C3A, 0x1907, 0x8C3A, 0x1907)
        assert (h[6], h[10], h[11]) == (8, 6, 1)
        pos, kv = 64, {}
        while pos < 64 + h[12]:
            (n,) = struct.unpack_from("<I", data, pos)
            key, value = data[pos + 4 : pos + 4 + n].split(b"\0", 1)
            kv[key.decode()] = value.rstrip(b"\0").decode()
            pos += 4 + n + (-n % 4)
        sh_meta = np.array([[float(v) for v in ln.split()] for ln in kv["sh"].strip().split("\n")])
        np.testing.assert_allclose(sh_meta, self._parse_sh_txt(out), rtol=1e-8, atol=1e-12)
        (size,) = struct.unpack_from("<I", data, pos)
        assert size == 8 * 8 * 4
        packed = np.frombuffer(data[pos + 4 : pos + 4 + 6 * size], "<u4").reshape(6, 8, 8)

        def unpack(bits, mbits):  # unsigned float, 5-bit exponent (GL ES 3.0 §2.1.3)
            e, m = bits >> mbits, (bits & ((1 << mbits) - 1)) / 2.0**mbits
            return np.where(e == 0, m * 2.0**-14, (1 + m) * 2.0 ** (e.astype(float) - 15))

        faces = np.stack([unpack(packed & 0x7FF, 6), unpack((packed >> 11) & 0x7FF, 6),
                          unpack(packed >> 22, 5)], -1)  # fmt: skip
        # Filament's texel at GL direction g shows world g: shbake's mirror cube (texel at GL g
        # shows world (-g_x, g_y, g_z)) looked up at GL (-g_x, g_y, g_z)
        residual = load_source(sky_asset["h5"]).environment()
        shbake_cube = cube_pyramid(mirror_cube(residual, 16))[1]
        d = cube_directions(8)[0]  # world directions of shbake's texels
        gl_of_filament_texel = d * [-1, 1, 1]  # Filament's texel (k, i, j) shows world = its GL g
        want = np.empty_like(shbake_cube)
        for k in range(6):  # the shbake texel whose world direction is that g
            for i in range(8):
                for j in range(8):
                    g = gl_of_filament_texel[k, i, j]
                    match = np.argmax(d.reshape(-1, 3) @ g)
                    want[k, i, j] = shbake_cube.reshape(-1, 3)[match]
        np.testing.assert_allclose(faces, want, rtol=2**-5, atol=1e-6)  # 5-bit mantissa (B)
        assert np.abs(faces - shbake_cube).max() > 0.1 * shbake_cube.max()  # really mirrored


class TestUnity:
    """unity.write: SphericalHarmonicsL2 as Unity's SRP packs it (SHA/SHB/SHC), x mirrored."""

    def test_packed_probe_gives_e_over_pi(self, sky_asset):
        out = str(sky_asset["dir"] / "u.unity.json")
        doc = json.load(open(export_assets([sky_asset["h5"]], "unity", out)[0]))
        sh = np.array(doc["SphericalHarmonicsL2"])  # sh[c, i]
        # SHCoefficients.GetSHA/GetSHB/GetSHC, then SHEvalLinearL0L1 + SHEvalLinearL2
        sha = np.stack([sh[:, 3], sh[:, 1], sh[:, 2], sh[:, 0] - sh[:, 6]], -1)
        shb = np.stack([sh[:, 4], sh[:, 5], 3 * sh[:, 6], sh[:, 7]], -1)
        shc = sh[:, 8]
        d = fibonacci_sphere(N_DIRS)
        src = load_source(sky_asset["h5"])
        n = d * [-1, 1, 1]  # Unity's frame: x mirrored

        def shade(nn):
            x, y, z = nn[:, 0], nn[:, 1], nn[:, 2]
            a = np.stack([x, y, z, np.ones_like(x)], -1) @ sha.T
            b = np.stack([x * y, y * z, z * z, z * x], -1) @ shb.T
            return a + b + (x * x - y * y)[:, None] * shc[None]

        from shbake.sh.basis import real_sh

        want = real_sh(d, 2) @ src.irradiance9 / np.pi
        assert np.abs(shade(n) - want).max() < 1e-12 * np.abs(want).max()
        assert np.abs(shade(d) - want).max() > 1e-3 * np.abs(want).max()  # frame not mirrored
        assert np.abs(np.pi * shade(n) - want).max() > 1e-3 * np.abs(want).max()
        assert doc["sun"]["intensity_lux"] == pytest.approx(np.pi * doc["sun"]["intensity_builtin"])


class TestExportCommand:
    """``shbake export``: the CLI over export_assets, its errors and byte-identical output."""

    def test_every_target_writes_and_is_deterministic(self, run_cli, sky_asset, tmp_path):
        outs = {
            "gltf": "a.gltf",
            "babylon": "a.env",
            "threejs": "a.json",
            "threejs-pmrem": "a_pmrem.ktx2",
            "ktx2": "a.ktx2",
            "filament": "a_sh.txt",
            "unity": "a.unity.json",
        }
        for target, name in outs.items():
            small = ["--size", "8", "--floor", "2", "--samples", "16"]
            small = small if target not in ("threejs", "unity") else []
            first = {}
            for run in (1, 2):
                d = tmp_path / f"{target}{run}"
                d.mkdir()
                code, stdout, err = run_cli(
                    "export", sky_asset["h5"], "--to", target, "-o", d / name, *small, "--json"
                )
                assert code == 0, err
                written = json.loads(stdout)["written"]
                files = {os.path.basename(p): open(p, "rb").read() for p in written}
                if run == 1:
                    first = files
            assert files == first, target  # same inputs -> identical bytes

    @pytest.mark.parametrize(
        ("target", "args", "named"),
        [
            ("threejs", ["--size", "8"], "--size"),
            ("unity", ["--env", "x.exr", "--samples", "16"], "--env, --samples"),
            ("threejs", ["--sun-radius", "5"], "--sun-radius"),
            ("filament", ["--lod-mapping", "gltf-ibl-sampler"], "--lod-mapping"),
            ("threejs-pmrem", ["--lod-mapping", "filament"], "--lod-mapping"),
            ("ktx2", ["--babylon-scene", "right-handed"], "--babylon-scene"),
        ],
    )
    def test_option_the_target_does_not_read_is_refused(
        self, run_cli, sky_asset, tmp_path, target, args, named
    ):
        out = tmp_path / "x.out"
        code, _, err = run_cli("export", sky_asset["h5"], "--to", target, "-o", out, *args)
        lines = [x for x in err.splitlines() if x.startswith("shbake: error:")]
        assert code == 1 and len(lines) == 1 and named in lines[0] and target in lines[0], err
        assert os.listdir(tmp_path) == []

    def test_options_of_target(self):
        from shbake.batch.export import TARGET_OPTIONS, options_of_target
        from shbake.format.exports import TARGETS

        cube = {"env_path", "size", "floor", "samples", "sun_radius_deg"}
        assert options_of_target("threejs") == options_of_target("unity") == frozenset()
        assert options_of_target("filament") == options_of_target("threejs-pmrem") == cube
        assert options_of_target("ktx2") == cube | {"mapping"}
        assert options_of_target("gltf") == options_of_target("babylon") == set(TARGET_OPTIONS)
        assert all(options_of_target(t) <= set(TARGET_OPTIONS) for t in TARGETS)

    def test_errors(self, run_cli, sky_asset, tmp_path, monkeypatch):
        """Bad targets, inputs and output names get one line, before any cube chain is baked."""

        def no_bake(*args, **kwargs):
            raise AssertionError("a cube chain was baked for an export that is refused")

        monkeypatch.setattr("shbake.batch.export.prefilter_chain", no_bake)
        code, _, err = run_cli("export", sky_asset["h5"], "--to", "unreal", "-o", tmp_path / "x")
        assert code == 2 and "unreal" in err
        code, _, err = run_cli(
            "export",
            sky_asset["h5"],
            "--to",
            "gltf",
            "-o",
            tmp_path / "x.gltf",
            "--env",
            tmp_path / "missing.exr",
        )
        assert code == 1 and err.startswith("shbake: error:")
        for target, name, ending in [("gltf", "x.glb", ".gltf"), ("babylon", "x.babylon", ".env"),
                                     ("filament", "x.ktx", "_sh.txt"), ("ktx2", "x.ktx", ".ktx2"),
                                     ("threejs-pmrem", "x.exr", ".ktx2")]:  # fmt: skip
            code, _, err = run_cli("export", sky_asset["h5"], "--to", target, "-o", tmp_path / name)
            assert code == 1 and ending in err and err.count("\n") == 1, (target, err)
        assert os.listdir(tmp_path) == []

    @pytest.mark.parametrize(
        ("args", "named"),
        [
            (["--lod-mapping", "filament"], "--lod-mapping babylon"),
            (["--babylon-scene", "right-handed"], "--rotate 180"),
            (["--floor", "1", "--size", "1"], "--size"),
        ],
    )
    def test_babylon_env_refusals(self, run_cli, sky_asset, tmp_path, args, named):
        """What a .env cannot hold is refused with one line, nothing written."""
        out = tmp_path / "x.env"
        small = ["--size", "8", "--floor", "2", "--samples", "16"]
        code, _, err = run_cli("export", sky_asset["h5"], "--to", "babylon", "-o", out, *small,
                               *args)  # fmt: skip
        lines = [x for x in err.splitlines() if x.startswith("shbake: error:")]
        assert code == 1 and len(lines) == 1 and named in lines[0], err
        assert os.listdir(tmp_path) == []

    def test_splitsum_probe_to_ktx2(self, run_cli, tmp_path):
        """A split-sum probe exports its map's cube chain (--env, SHA-256 checked); not SH."""
        path = os.path.join(SHARED, "hdri", "forest.exr")
        probe = tmp_path / "p.h5"
        code, _, err = run_cli(
            "split-sum",
            path,
            "-o",
            probe,
            "--size",
            "16",
            "--min-size",
            "8",
            "--alphas",
            "0.25,1",
            "--samples",
            "16",
            "-q",
        )
        assert code == 0, err
        code, _, err = run_cli(
            "export",
            probe,
            "--to",
            "ktx2",
            "-o",
            tmp_path / "p.ktx2",
            "--env",
            path,
            "--size",
            "8",
            "--samples",
            "16",
        )
        assert code == 0, err
        r = _ktx2(str(tmp_path / "p.ktx2"))
        assert (r["faceCount"], r["levelCount"], r["pixelWidth"]) == (6, 4, 8)
        code, _, err = run_cli("export", probe, "--to", "threejs", "-o", tmp_path / "p.json")
        assert code == 1 and "env_sh" in err
        other = os.path.join(SHARED, "hdri", "city.exr")
        code, _, err = run_cli(
            "export", probe, "--to", "ktx2", "-o", tmp_path / "q.ktx2", "--env", other
        )
        assert code == 1 and "SHA-256" in err

    def test_out_dir_for_several_assets(self, run_cli, sky_asset, tmp_path):
        code, _, err = run_cli("export", sky_asset["h5"], sky_asset["h5"], "--to", "unity",
                               "-o", tmp_path / "x.unity.json")  # fmt: skip
        assert code == 2 and "--out-dir" in err
        code, _, err = run_cli(
            "export", sky_asset["h5"], "--to", "unity", "--out-dir", tmp_path / "u"
        )
        assert code == 0, err
        assert (tmp_path / "u" / "s.unity.json").exists()


class TestBabylonEnv:
    """babylon.write_env: Babylon's .env layout (``environmentTextureTools``), read here as
    ``GetEnvInfo``/``CreateRadianceImageDataArrayBufferViews`` read it; the rendering is
    checked in Babylon itself by ``tests/test_engine_render.py``."""

    @staticmethod
    def _read(path: str) -> tuple[dict, bytes]:
        data = open(path, "rb").read()
        assert data[:8] == bytes([0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36])
        end = data.index(b"\0", 8)
        return json.loads(data[8:end].decode("ascii")), data[end + 1 :]

    def test_layout_and_the_sun_beside_it(self, sky_asset, tmp_path):
        out = str(tmp_path / "s.env")
        written = export_assets([sky_asset["h5"]], "babylon", out, size=16, floor=4, samples=8)
        assert written == [out, str(tmp_path / "s_lights.gltf")]  # the asset has a sun
        info, payload = self._read(out)
        assert info["version"] == 2 and info["width"] == 16 and info["imageType"] == "image/png"
        mips = info["specular"]["mipmaps"]
        assert len(mips) == 6 * (4 + 1)  # 16² … 1², as Babylon requires
        assert [m["position"] for m in mips] == list(
            np.cumsum([0] + [m["length"] for m in mips])[:-1]
        )
        assert sum(m["length"] for m in mips) == len(payload)
        assert all(payload[m["position"] : m["position"] + 8] == b"\x89PNG\r\n\x1a\n" for m in mips)
        # alpha = 1 at 4² (level 2): lod = s log2(16 alpha) reaches 2 at alpha = 1
        assert info["specular"]["lodGenerationScale"] == pytest.approx(2 / 4)
        assert info["shbake"]["roughness_lod_mapping"] == "babylon"
        assert info["shbake"]["specular_roughness"][2:] == [1.0, 1.0, 1.0]
        assert set(info["irradiance"]) == {"x", "y", "z", "xx", "yy", "zz", "yz", "zx", "xy"}
        lights = json.load(open(tmp_path / "s_lights.gltf"))
        assert lights["extensions"]["KHR_lights_punctual"]["lights"][0]["type"] == "directional"

    def test_rgbd_range_is_clamped_with_one_warning(self, sky_asset, tmp_path, capfd):
        from shbake.format.exports.babylon import write_env

        src = load_source(sky_asset["h5"])
        levels = [np.full((6, n, n, 3), 0.5) for n in (4, 2, 1)]
        levels[0][0, 0, 0] = 1000.0
        out = str(tmp_path / "c.env")
        write_env(src, out, levels, [0.0, 1.0, 1.0], "babylon", "left-handed")
        err = capfd.readouterr().err
        assert err.count("shbake: warning:") == 1 and "RGBD (.env) maximum 255" in err
        info, _ = self._read(out)
        assert info["specular"]["lodGenerationScale"] == pytest.approx(1 / 2)
