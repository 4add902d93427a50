"""Lights fitted with the SH to the irradiance (``project-env --lights``, issue 33).

Every check is against something the fit does not compute: brute-force irradiance of the
map (:mod:`shbake.reference.irradiance`) at a different lattice than the fit's, known
synthetic lights, the energy integrated over the sphere by an independent quadrature,
the unconstrained least squares solved here with numpy, and three.js itself (node).
"""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from shbake.bakers.env_lights import choose_lights, fit_lights, irradiance_target
from shbake.bakers.env_sh import bake_env_sh
from shbake.conventions import REC709_LUMINANCE
from shbake.envmap import Environment, load_environment
from shbake.envmap.layouts import latlong_directions, latlong_solid_angles
from shbake.envmap.sun import remove_lights
from shbake.errors import ParameterError
from shbake.evaluation.env_sh import brute_force_reference
from shbake.format.asset import read_asset, write_asset
from shbake.reference.irradiance import brute_force_irradiance
from shbake.sh.basis import real_sh
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.shader import shader
from shbake.shading.sphere_light import sphere_lambert, sphere_power
from tests.helpers import map_path, write_test_exr

ENGINES = os.path.join(os.path.dirname(__file__), "..", "engines")
LIGHTS = np.array([[0.3, 0.8, -0.52], [-0.7, 0.2, 0.68]])
LIGHTS /= np.linalg.norm(LIGHTS, axis=1, keepdims=True)


def sky_with_lights(h=128, radius_deg=1.0):
    """A smooth sky (radiance of bands ≤ 1, so its irradiance is exact in L2) and two discs;
    returns the map and each disc's excess energy ``Σ (L − sky) Ω`` (RGB)."""
    d = latlong_directions(h, 2 * h)
    sky = (0.5 + 0.3 * d[..., 1:2]) * np.array([0.6, 0.8, 1.0])
    img = sky.copy()
    omega = latlong_solid_angles(h, 2 * h)
    energies = []
    for s, radiance in zip(LIGHTS, ([4000.0, 3600.0, 3000.0], [900.0, 1000.0, 1200.0]),
                           strict=True):  # fmt: skip
        disc = (d @ s) > np.cos(np.radians(radius_deg))
        img = np.where(disc[..., None], np.array(radiance), img)
        energies.append(((img - sky) * omega[..., None])[disc].sum(axis=0))
    return Environment(img.astype(np.float32), "latlong"), np.array(energies), sky


def _angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


class TestSyntheticLights:
    def test_recovers_two_known_lights(self):
        env, energies, _ = sky_with_lights()
        fit = fit_lights(irradiance_target(env), 2)
        assert fit.count == 2
        assert np.all(_angle_deg(fit.directions, LIGHTS) < 0.7)  # discs of 1°, texels of 1.4°
        np.testing.assert_allclose(fit.irradiance, energies, rtol=5e-3)
        # against brute force at another lattice than the fit's; the largest error is where a
        # disc sets (its terminator is 1° wide, a directional light's is sharp)
        q = fibonacci_sphere(2048)
        d, om, L = env.samples()
        ref = brute_force_irradiance(d, om, L, q) @ REC709_LUMINANCE
        model = real_sh(q, 2) @ fit.sh + np.maximum(q @ fit.directions.T, 0.0) @ fit.irradiance
        rel = np.abs(model @ REC709_LUMINANCE - ref) / ref
        assert rel.mean() < 2e-4 and rel.max() < 1e-2

    def test_auto_takes_the_fewest_lights_meeting_the_tolerance(self):
        env, _, _ = sky_with_lights()
        fit, tried = choose_lights(irradiance_target(env), 0.002)
        assert [f.count for f in tried] == [0, 1, 2] and fit.count == 2
        assert tried[1].mean_error > 0.002 >= fit.mean_error

    def test_irradiance_lmax_0(self):
        """Lights with the constant alone (``--irradiance-lmax 0``) on a constant sky with
        two discs: the discs are found, with their energy."""
        env, energies, sky = sky_with_lights()
        flat = env.pixels - sky + 0.5  # the sky's gradient (band 1) taken out
        fit = fit_lights(irradiance_target(Environment(flat.astype(np.float32), "latlong")), 2,
                         lmax=0)  # fmt: skip
        assert fit.sh.shape[0] == 1
        assert np.all(_angle_deg(fit.directions, LIGHTS) < 0.7)
        np.testing.assert_allclose(fit.irradiance, energies, rtol=5e-3)

    def test_black_map_gives_no_light(self):
        env = Environment(np.zeros((16, 32, 3), np.float32), "latlong")
        fit, _ = choose_lights(irradiance_target(env, 256), 0.01)
        assert fit.count == 0 and not fit.sh.any()

    def test_black_map_with_a_bright_patch(self, run_cli, tmp_path):
        """A 1e5 patch on a black map: half the normals see nothing, so a relative error
        there is measured against the weights' floor (it was 1.7e300 and the asset was
        refused as invalid); the patch is found as one light."""
        px = np.zeros((32, 64, 3))
        px[8:11, 20:23] = 1e5
        path = write_test_exr(tmp_path / "patch.exr", px)
        code, out, err = run_cli("project-env", path, "-o", tmp_path / "p.h5", "--lights", "auto",
                                 "--json", "-q")  # fmt: skip
        assert code == 0, err
        lights = json.loads(out)["lights"]
        assert lights["count"] >= 1
        assert all(np.isfinite(f["max_error"]) and f["max_error"] < 1e7 for f in lights["tried"])
        d = read_asset(str(tmp_path / "p.h5"))["/lights/direction"][0]
        centre = latlong_directions(32, 64)[9, 21]
        assert _angle_deg(d, centre) < 8.0  # texels of 5.6°

    def test_round_off_is_not_ringing(self, run_cli, tmp_path):
        """One 1e5 texel on a black 16×32 map: with a light fitted the SH part's minimum is
        −1e-13 against a mean of 849 (round-off, no warning); projected plainly it rings at
        −135, and that is still reported."""
        px = np.zeros((16, 32, 3))
        px[5, 10] = 1e5
        path = write_test_exr(tmp_path / "spike.exr", px)
        for extra, rings in ((["--lights", "1"], False), ([], True)):
            code, out, err = run_cli("project-env", path, "-o", tmp_path / "s.h5", "--json", "-q",
                                     *extra)  # fmt: skip
            assert code == 0, err
            warned = [w for w in json.loads(out)["warnings"] if "rings below zero" in w]
            assert bool(warned) == rings, warned

    def test_refuses_bad_counts(self):
        env, _, _ = sky_with_lights(h=16)
        with pytest.raises(ParameterError, match="number of lights"):
            fit_lights(irradiance_target(env, 64), 9)
        with pytest.raises(ParameterError, match="tolerance"):
            choose_lights(irradiance_target(env, 64), 0.0)


class TestSphereLights:
    """``--light-shape sphere``: two uniform caps of 8° on the smooth sky, known exactly."""

    RADIUS_DEG = 8.0

    @pytest.fixture(scope="class")
    @classmethod
    def caps(cls, tmp_path_factory):
        """``(map as read from its EXR, the caps' energies, the sky)``."""
        env, energies, sky = sky_with_lights(h=128, radius_deg=cls.RADIUS_DEG)
        path = write_test_exr(tmp_path_factory.mktemp("caps") / "caps.exr", env.pixels)
        return load_environment(str(path), quiet=True), energies, sky

    def test_recovers_radii_directions_and_energy(self, caps):
        env, energies, _ = caps
        fit = fit_lights(irradiance_target(env), 2, shape="sphere")
        assert fit.count == 2
        assert np.all(_angle_deg(fit.directions, LIGHTS) < 0.3)
        np.testing.assert_allclose(np.degrees(fit.radii), self.RADIUS_DEG, atol=0.3)
        # a cap's energy L Ω (the discs' excess over the sky, summed over their texels)
        np.testing.assert_allclose(sphere_power(fit.radii)[:, None] * fit.irradiance, energies,
                                   rtol=5e-3)  # fmt: skip

    def test_beats_points_against_brute_force(self, caps):
        """At 2048 normals of another lattice: the caps' roll-off across the horizon is
        modelled (what is left: the discs are texels of 1.4°, not caps), where two points
        (and their SH) are 5.7 % off on average and 75 % at the terminators."""
        env, _, _ = caps
        q = fibonacci_sphere(2048)
        d, om, L = env.samples()
        ref = brute_force_irradiance(d, om, L, q) @ REC709_LUMINANCE
        errors = {}
        for shape in ("point", "sphere"):
            fit = fit_lights(irradiance_target(env), 2, shape=shape)
            model = real_sh(q, 2) @ fit.sh + sphere_lambert(q @ fit.directions.T,
                                                            fit.radii[None, :]) @ fit.irradiance
            errors[shape] = np.abs(model @ REC709_LUMINANCE - ref) / ref
        assert errors["sphere"].mean() < 2e-3 and errors["sphere"].max() < 3e-2
        assert errors["point"].mean() > 20 * errors["sphere"].mean()

    def test_energy_is_conserved(self, caps):
        """∫ E dn of SH + spheres (100k normals) is π ∫ L dω of the map."""
        env, _, _ = caps
        fit = fit_lights(irradiance_target(env), 2, shape="sphere")
        q = fibonacci_sphere(100_000)
        model = real_sh(q, 2) @ fit.sh + sphere_lambert(q @ fit.directions.T,
                                                        fit.radii[None, :]) @ fit.irradiance
        _, om, L = env.samples()
        np.testing.assert_allclose(model.mean(axis=0) * 4.0 * np.pi,
                                   np.pi * (L * om[:, None]).sum(axis=0), rtol=1e-4)  # fmt: skip

    def test_asset_shades_them(self, caps, tmp_path):
        """The asset (``/lights/angular_radius``) read back and shaded by the registry's
        irradiance and tangent shaders (SH and matrix forms), against brute force; its lighting
        SH is the map's less the caps' exact SH (bands the fit does not replace: 3 and 4),
        within the 1e-3 by which the discs of texels are not caps (as points: 6 % of the
        caps' SH)."""
        env, _, sky = caps
        asset, summary = bake_env_sh(env, lmax=4, lights=2, light_shape="sphere",
                                     provenance={"command_line": "test"})  # fmt: skip
        path = str(tmp_path / "a.h5")
        write_asset(path, asset)
        a = read_asset(path)
        assert a.attrs["format_version"] == 4
        np.testing.assert_allclose(np.degrees(a["/lights/angular_radius"]), self.RADIUS_DEG,
                                   atol=0.3)  # fmt: skip
        q = fibonacci_sphere(2048)
        d, om, L = env.samples()
        ref = brute_force_irradiance(d, om, L, q) @ REC709_LUMINANCE
        got = shader(a, "irradiance").irradiance(q) @ REC709_LUMINANCE
        assert (np.abs(got - ref) / ref).max() < 3e-2
        assert summary["lights"]["shape"] == "sphere"
        ref_t = brute_force_irradiance(d, om, L, q, tangent=True) @ REC709_LUMINANCE
        for got_t in (shader(a, "tangent-sh").irradiance(q),
                      shader(a, "tangent").shade(q, None, tangents=q)):  # fmt: skip
            rel_t = np.abs(got_t @ REC709_LUMINANCE - ref_t) / ref_t
            assert rel_t.mean() < 1e-3 and rel_t.max() < 5e-3  # 1.8e-4, 1.5e-3 when written
        as_points = shader(a, "tangent-sh")
        as_points.light_radii = np.zeros_like(as_points.light_radii)
        rel_p = np.abs(as_points.irradiance(q) @ REC709_LUMINANCE - ref_t) / ref_t
        assert rel_p.max() > 20 * rel_t.max()  # the caps as points: 15 %
        sky_sh = Environment(sky.astype(np.float32), "latlong").project(4)
        caps_sh = env.project(4) - sky_sh
        np.testing.assert_allclose(a["/lighting/sh"][9:], sky_sh[9:],
                                   atol=2e-3 * np.abs(caps_sh[9:]).max())  # fmt: skip

    @pytest.mark.slow
    @pytest.mark.parametrize("name", ["night", "studio"])
    def test_three_spheres_within_one_percent(self, name):
        """The two maps no point lights fit within 1 % (docs/BENCHMARKS.md): three spheres
        + L2 do, by the asset's shader against brute force of the map at the 2048 normals of
        the acceptance (night 0.92 % / 8.5 %, studio 0.23 % / 8.3 % when written)."""
        env = load_environment(str(map_path(name)), quiet=True)
        asset, _ = bake_env_sh(env, lights=3, tangent=False, light_shape="sphere")
        ref = brute_force_reference(env, n_dirs=2048)
        got = shader(asset, "irradiance").irradiance(ref["dirs"]) @ REC709_LUMINANCE
        rel = np.abs(got - ref["irradiance"]) / ref["irradiance"]
        assert rel.mean() <= 0.01 and rel.max() <= 0.10

    def test_never_costs_more_than_points(self):
        """night: the fit kept is the one least costly once its SH part is held non-negative,
        not the least optimum before that, so spheres beat the points with one light (2.10 %
        mean against 2.15 %) and two (1.45 % against 1.54 %). Judged before holding, one
        light gave the points (a sphere fit held at 2.82 %) and two gave the points or the
        spheres by the CPU's rounding (an optimum with a radius at the 30° limit, 12.6 once
        held against the points' 6.4, came first without AVX-512)."""
        from shbake.bakers.env_lights import _Problem

        target = irradiance_target(load_environment(str(map_path("night")), quiet=True))
        problem = _Problem(target, 2)
        for k in (1, 2):
            points = fit_lights(target, k)
            spheres = fit_lights(target, k, shape="sphere", points=points)
            assert problem.cost(spheres) < problem.cost(points)
            assert spheres.mean_error < points.mean_error
            assert spheres.radii.all()

    def test_points_returned_when_no_sphere_fit_costs_less(self, monkeypatch):
        """A sphere of radius 0 is a point: when every sphere fit costs more (here each is
        finished with its lights dropped, SH alone), the points' fit is returned as it is."""
        import shbake.bakers.env_lights as env_lights

        target = irradiance_target(load_environment(str(map_path("night")), quiet=True))
        points = fit_lights(target, 1)
        finish = env_lights._finish
        monkeypatch.setattr(env_lights, "_finish", lambda p, d, r: finish(p, d[:0], r[:0]))
        assert fit_lights(target, 1, shape="sphere", points=points) is points
        monkeypatch.setattr(env_lights, "_finish", finish)
        assert fit_lights(target, 1, shape="sphere", points=points) is not points

    def test_refuses_an_unknown_shape(self, caps):
        with pytest.raises(ParameterError, match="--light-shape"):
            bake_env_sh(caps[0], lights=1, light_shape="disc")


class TestConstraints:
    @pytest.fixture(scope="class")
    @classmethod
    def esplanade(cls):
        return load_environment(str(map_path("esplanade")), quiet=True)

    def test_energy_is_conserved(self, esplanade):
        """∫ E(n) dn of SH + lights over the sphere (100k-point quadrature, not the fit's
        lattice) equals π ∫ L dω of the map (its texels times their exact solid angles)."""
        fit = fit_lights(irradiance_target(esplanade), 2)
        q = fibonacci_sphere(100_000)
        model = real_sh(q, 2) @ fit.sh + np.maximum(q @ fit.directions.T, 0.0) @ fit.irradiance
        integral = model.mean(axis=0) * 4.0 * np.pi
        _, om, L = esplanade.samples()
        np.testing.assert_allclose(integral, np.pi * (L * om[:, None]).sum(axis=0), rtol=1e-4)
        assert fit.irradiance.sum() > 0.3 * (L * om[:, None]).sum()  # the lights carry energy

    def test_sh_alone_is_never_negative(self):
        """studio without lights: the unconstrained least squares (numpy, here) rings below
        zero; the fit's SH does not, at 100k normals."""
        env = load_environment(str(map_path("studio")), quiet=True)
        target = irradiance_target(env)
        y = target.irradiance @ REC709_LUMINANCE
        w = 1.0 / y
        Y = real_sh(target.normals, 2)
        A = Y[:, 1:] * w[:, None]
        b = (target.irradiance - target.energy / 4.0) * w[:, None]
        free = np.linalg.lstsq(A, b, rcond=None)[0]
        q = fibonacci_sphere(100_000)
        Yq = real_sh(q, 2)
        assert (target.energy / 4.0 + Yq[:, 1:] @ free).min() < 0.0
        fit = fit_lights(target, 0)
        sh = Yq @ fit.sh
        assert sh.min() > -1e-6 * sh.mean()


class TestScale:
    """The fit is free of the map's scale: a map × k gives the same lights, with intensities
    and SH × k. In the map's own units the SLSQP solve that holds the SH part non-negative
    could not meet its absolute tolerance: × 1e30 every solve ran its 200 steps and the SH
    still went below zero (``project-env --lights 1 --light-shape sphere`` on a black 64×128
    map with one texel of 1e30: 29 s, 1.6 s now); × 1e-30 it gave up at once (studio's SH off
    by 1e34)."""

    @staticmethod
    def solves(monkeypatch) -> list:
        """The status of every SLSQP solve from now on (0: converged)."""
        import scipy.optimize

        statuses = []
        original = scipy.optimize.minimize

        def minimize(*args, **kwargs):
            res = original(*args, **kwargs)
            statuses.append(res.status)
            return res

        monkeypatch.setattr(scipy.optimize, "minimize", minimize)
        return statuses

    @pytest.fixture(scope="class")
    @classmethod
    def studio(cls):
        """The studio map (its SH alone rings below zero) and its fit without lights."""
        env = load_environment(str(map_path("studio")), quiet=True)
        return env, fit_lights(irradiance_target(env), 0)

    @pytest.mark.parametrize("k", [1e30, 1e-30])
    def test_sh_held_non_negative_at_any_scale(self, monkeypatch, studio, k):
        env, plain = studio
        scaled = Environment((env.pixels.astype(np.float64) * k).astype(np.float32), "latlong")
        statuses = self.solves(monkeypatch)
        fit = fit_lights(irradiance_target(scaled), 0)
        assert statuses and set(statuses) == {0}, statuses
        np.testing.assert_allclose(fit.sh / k, plain.sh, rtol=0,
                                   atol=1e-6 * np.abs(plain.sh).max())  # fmt: skip
        sh = real_sh(fibonacci_sphere(100_000), 2) @ fit.sh
        assert sh.min() > -1e-6 * sh.mean()

    @pytest.mark.parametrize(("args", "scales"), [
        (("--lights", "2"), (1e-30, 1e30)),
        (("--lights", "1", "--light-shape", "sphere"), (1e30,)),
    ])  # fmt: skip
    def test_one_texel(self, run_cli, monkeypatch, tmp_path, args, scales):
        """A black map but for one texel, through the command: one light toward the texel at
        every scale (a second light of about 1e-17 of the energy, round-off of the intensities'
        solve, was kept at some scales, not at others:
        :data:`shbake.bakers.env_lights.LIGHT_FLOOR`)."""
        runs = {}
        statuses = self.solves(monkeypatch)
        for k in (1.0, *scales):
            px = np.zeros((32, 64, 3))
            px[10, 20] = k
            path = write_test_exr(tmp_path / f"one-{k:g}.exr", px)
            out = tmp_path / f"one-{k:g}.h5"
            code, stdout, err = run_cli("project-env", path, "-o", out, *args, "--json", "-q")
            assert code == 0, err
            runs[k] = json.loads(stdout)["lights"]["lights"], read_asset(str(out))
        assert statuses and set(statuses) == {0}, statuses
        (want,), plain = runs[1.0]
        assert _angle_deg(np.array(want["direction"]), latlong_directions(32, 64)[10, 20]) < 6.0
        for k in scales:
            (got,), asset = runs[k]
            np.testing.assert_allclose(got["direction"], want["direction"], rtol=0, atol=1e-9)
            np.testing.assert_allclose(np.array(got["irradiance"]) / k, want["irradiance"],
                                       rtol=1e-6)  # fmt: skip
            for name in ("/lighting/sh", "/irradiance/sh"):
                np.testing.assert_allclose(asset[name] / k, plain[name], rtol=0,
                                           atol=1e-6 * max(want["irradiance"]))  # fmt: skip


class TestAsset:
    def test_round_trip_and_shading(self, tmp_path):
        write_test_exr(tmp_path / "sky.exr", sky_with_lights()[0].pixels)
        env = load_environment(str(tmp_path / "sky.exr"), quiet=True)
        asset, summary = bake_env_sh(env, lmax=4, lights="auto", light_tol=0.002,
                                     provenance={"command_line": "test"})  # fmt: skip
        path = str(tmp_path / "a.h5")
        write_asset(path, asset)
        a = read_asset(path)
        assert a.attrs["format_version"] == 4 and a["/lights/direction"].shape == (2, 3)
        assert a["/lighting/sh"].shape == (25, 3)
        q = fibonacci_sphere(2048)
        d, om, L = env.samples()
        ref = brute_force_irradiance(d, om, L, q)
        got = shader(a, "irradiance").irradiance(q)
        rel = np.abs(got - ref) @ REC709_LUMINANCE / (ref @ REC709_LUMINANCE)
        assert rel.mean() < 2e-4 and rel.max() < 1e-2
        # tangent irradiance, against its own brute force: the residual SH carries it too
        ref_t = brute_force_irradiance(d, om, L, q, tangent=True) @ REC709_LUMINANCE
        got_t = shader(a, "tangent-sh").irradiance(q) @ REC709_LUMINANCE
        assert np.max(np.abs(got_t - ref_t) / ref_t) < 5e-3
        assert summary["lights"]["count"] == 2 and summary["lights"]["met"]

    def test_rotation_turns_lights_and_sh(self, tmp_path):
        from shbake.envmap.turn import turn_matrix

        write_test_exr(tmp_path / "sky.exr", sky_with_lights(h=64)[0].pixels)
        env = load_environment(str(tmp_path / "sky.exr"), quiet=True)
        R = turn_matrix(40.0)
        plain, _ = bake_env_sh(env, lights=2)
        turned, _ = bake_env_sh(env, lights=2, rotation=R)
        q = fibonacci_sphere(500)
        got, want = shader(turned).irradiance(q @ R.T), shader(plain).irradiance(q)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


class TestRemoveLights:
    def test_takes_the_lights_energy_from_around_them(self):
        env, energies, sky = sky_with_lights()
        residual, report = remove_lights(env, LIGHTS, energies, radius_deg=5.0)
        assert report["shortfall_fraction"] < 1e-3
        np.testing.assert_allclose(report["removed"], energies, rtol=1e-3)
        assert residual.pixels.max() < 1.0  # the discs are gone, the sky is kept

    def test_reports_what_is_not_there(self):
        env, energies, _ = sky_with_lights()
        _, report = remove_lights(env, -LIGHTS, energies, radius_deg=5.0)
        assert report["shortfall_fraction"] > 0.99


class TestCommand:
    def test_lights_auto(self, run_cli, tmp_path):
        out = tmp_path / "e.h5"
        code, stdout, err = run_cli("project-env", map_path("esplanade"), "-o", out, "--lights",
                                    "auto", "--tol", "0.01", "--json", "-q")  # fmt: skip
        assert code == 0, err
        s = json.loads(stdout)
        assert s["lights"]["count"] == 2 and s["lights"]["mean_error"] <= 0.01
        a = read_asset(str(out))
        assert a["/lights/irradiance"].shape == (2, 3)

    @pytest.mark.parametrize(
        ("args", "fragment"),
        [
            (("--lights", "2", "--tol", "0.01"), "--tol applies to --lights auto"),
            (("--lights", "1", "--extract-sun"), "exclude each other"),
            (("--lights", "1", "--window", "hann"), "no --window"),
            (("--lights", "9"), "--lights"),
        ],
    )
    def test_refused(self, run_cli, tmp_path, args, fragment):
        """Settings that exclude each other are usage errors (exit 2), refused before the map
        is read."""
        out = tmp_path / "x.h5"
        got, _, err = run_cli("project-env", map_path("esplanade"), "-o", out, *args)
        assert got == 2 and fragment in err and not out.exists()
        assert list(tmp_path.iterdir()) == []


def _three(scene_json, dirs, folder):
    path = os.path.join(folder, "dirs.json")
    with open(path, "w") as f:
        json.dump(dirs.tolist(), f)
    r = subprocess.run(["node", os.path.join(ENGINES, "three_irradiance.mjs"), scene_json, path],
                       cwd=ENGINES, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    return np.array(json.loads(r.stdout)["irradiance"])


ACCEPTANCE = {  # map: (mean, max) the three.js export of --lights auto --tol 0.01 meets
    "city": (0.01, 0.10),
    "esplanade": (0.01, 0.10),
    "forest": (0.01, 0.10),
    "sunset": (0.01, 0.10),
    # measured optimum with 3 directional lights (docs/BENCHMARKS.md says why 1 % is out of
    # reach: night's glow spans the horizon, studio's softboxes are 10-20° wide)
    "night": (0.0115, 0.10),
    "studio": (0.0150, 0.23),
}


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
@pytest.mark.parametrize("name", list(ACCEPTANCE))
def test_three_js_export_against_brute_force(name, tmp_path):
    """Issue 33's acceptance: 9 SH coefficients per channel + at most 3 lights, evaluated by
    three.js (ObjectLoader, LightProbe.getIrradianceAt, DirectionalLight) at 2048 Fibonacci
    normals, against brute force of the original map; auto takes the fewest lights."""
    from shbake.batch.project_env import project_environment

    path = str(map_path(name))
    out = str(tmp_path / f"{name}.h5")
    summary = project_environment(path, out, lights="auto", light_tol=0.01,
                                  exports=("threejs",), quiet=True)  # fmt: skip
    ref = brute_force_reference(load_environment(path, quiet=True), n_dirs=2048)
    got = _three(summary["threejs"], ref["dirs"], str(tmp_path)) @ REC709_LUMINANCE
    rel = np.abs(got - ref["irradiance"]) / ref["irradiance"]
    mean, top = ACCEPTANCE[name]
    lights = summary["lights"]
    print(f"\n{name}: {lights['count']} lights, mean {rel.mean():.3%}, max {rel.max():.2%}")
    assert rel.mean() <= mean and rel.max() <= top
    assert lights["count"] <= 3
    tried = lights["tried"]
    assert all(f["mean_error"] > 0.01 for f in tried[:-1])  # no fewer lights would do


class TestPlan:
    """``shbake plan`` with a diffuse material and an engine export: lights first."""

    def test_plans_and_bakes_lights_within_the_tolerance(self, tmp_path):
        import shutil as sh

        from shbake.batch.plan import plan_scene
        from shbake.batch.scene import load_scene
        from shbake.batch.scene_bake import bake_scene

        sh.copy(map_path("esplanade"), tmp_path / "esplanade.exr")
        (tmp_path / "scene.toml").write_text(
            '[scene]\nname = "lit"\nexports = ["threejs"]\n[tolerances]\nirradiance = 0.01\n'
            '[[environments]]\nmap = "esplanade.exr"\n'
            '[[materials]]\nname = "plaster"\nkind = "diffuse"\n'
        )
        scene = load_scene(str(tmp_path / "scene.toml"))
        env_sh = next(a for a in plan_scene(scene)["assets"] if a["kind"] == "env_sh")
        assert env_sh["settings"]["lmax"] == 2 and env_sh["settings"]["lights"] >= 1
        assert env_sh["predicted_error"]["irradiance"] <= 0.01
        summary = bake_scene(scene)
        record = next(r for r in summary["records"].values() if r["id"] == env_sh["id"])
        # measured by the bake against brute force (1024 normals), not by the fit
        assert record["measured_error"]["irradiance"] <= 0.01
        assert "/lights/direction" in read_asset(env_sh["output"])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["night", "studio"])
def test_no_fit_at_the_chosen_directions_meets_one_percent(name):
    """Why night and studio keep wider :data:`ACCEPTANCE` bounds: at the directions
    ``--lights 3`` finds, the least mean relative luminance error that *any* 9 coefficients
    and 3 light luminances (``≥ 0``, energy kept) give at the 2048 acceptance normals — a
    linear programme solved here by scipy's HiGHS, not by the fit, with the SH part free to
    go negative — is above 1 %, and no more than the fit's own mean there."""
    from scipy import sparse
    from scipy.optimize import linprog

    env = load_environment(str(map_path(name)), quiet=True)
    fit = fit_lights(irradiance_target(env), 3)
    ref = brute_force_reference(env, n_dirs=2048)
    q, y = ref["dirs"], ref["irradiance"]
    _, omega, radiance = env.samples()
    energy = float((radiance @ REC709_LUMINANCE) @ omega)
    model = np.hstack([real_sh(q, 2)[:, 1:], np.maximum(q @ fit.directions.T, 0.0) - 0.25])
    A = sparse.csr_matrix(model / y[:, None])
    b = 1.0 - energy / 4.0 / y
    n, m = A.shape
    gap = -sparse.identity(n)
    k = fit.count
    res = linprog(
        np.concatenate([np.zeros(m), np.ones(n) / n]),
        A_ub=sparse.vstack([sparse.hstack([A, gap]), sparse.hstack([-A, gap])]),
        b_ub=np.concatenate([b, -b]),
        bounds=[(None, None)] * (m - k) + [(0, None)] * (k + n),
        method="highs",
    )
    assert res.status == 0
    own = real_sh(q, 2) @ fit.sh + np.maximum(q @ fit.directions.T, 0.0) @ fit.irradiance
    own_mean = float(np.mean(np.abs(own @ REC709_LUMINANCE - y) / y))
    print(f"\n{name}: least mean {res.fun:.3%}, the fit's {own_mean:.3%}")
    assert 0.01 < res.fun <= own_mean + 1e-6
