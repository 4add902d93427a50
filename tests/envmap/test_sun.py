"""Sun extraction on synthetic maps with a known light."""

import numpy as np
import pytest

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap import Environment
from shbake.envmap.layouts import latlong_directions, latlong_solid_angles, texels
from shbake.envmap.sun import extract_sun
from shbake.errors import ParameterError
from shbake.sh.projection import fejer_row_weights


def sky_with_sun(direction, radiance=1e5, radius_deg=0.6, h=256):
    d = latlong_directions(h, 2 * h)
    sky = 0.5 + 0.3 * np.clip(d[..., 1:2], 0, 1) * np.array([0.6, 0.8, 1.0])
    sun = (d @ direction) > np.cos(np.radians(radius_deg))
    img = np.where(sun[..., None], radiance, sky)
    return img.astype(np.float32), sun, sky


class TestExtractSun:
    def test_recovers_direction_and_energy(self):
        s = np.array([0.3, 0.8, -0.52])
        s /= np.linalg.norm(s)
        img, mask, sky = sky_with_sun(s)
        env = Environment(img, "latlong")
        sun, residual, report = extract_sun(env)
        assert report["extracted"]
        omega = latlong_solid_angles(256, 512)
        expected = ((img - sky) * omega[..., None])[mask].sum(axis=0)
        assert np.degrees(np.arccos(np.clip(sun.direction @ s, -1, 1))) < 0.2
        np.testing.assert_allclose(sun.energy, expected, rtol=2e-3)
        # The residual is the sky alone, to within the background estimate.
        assert residual.pixels.max() < 1.0

    def test_no_light_in_a_uniform_map(self):
        env = Environment(np.ones((32, 64, 3), np.float32), "latlong")
        sun, residual, report = extract_sun(env)
        assert sun is None and residual is env and not report["extracted"]

    def test_black_map(self):
        env = Environment(np.zeros((32, 64, 3), np.float32), "latlong")
        sun, _, _ = extract_sun(env)
        assert sun is None

    def test_rejects_absurd_radius(self):
        with pytest.raises(ParameterError):
            extract_sun(Environment(np.ones((8, 16, 3), np.float32), "latlong"), radius_deg=90)


def _straightforward_sun(env, radius_deg):
    """The module docstring's steps in plain numpy over the whole map (fresh texel
    geometry from :func:`shbake.envmap.layouts.texels`, no cap-only shortcuts)."""
    dirs, omega, mask = texels(env.layout, *env.shape)
    px = env.pixels.astype(np.float64)
    lum = np.where(mask, px @ REC709_LUMINANCE, -np.inf)
    d0 = dirs[np.unravel_index(int(np.argmax(lum)), lum.shape)]
    cosang = dirs @ d0
    cos_r, cos_2r = np.cos(np.radians(radius_deg)), np.cos(np.radians(2.0 * radius_deg))
    background = np.median(px[mask & (cosang < cos_r) & (cosang >= cos_2r)], axis=0)
    cap = mask & (cosang >= cos_r)
    excess = np.where(cap[:, :, None], np.maximum(px - background, 0.0), 0.0)
    weights = (np.repeat(fejer_row_weights(*env.shape)[:, None], env.shape[1], axis=1)
               if env.layout == "latlong" else omega)  # fmt: skip
    ex_lum = excess @ REC709_LUMINANCE
    direction = np.einsum("hw,hwk->k", ex_lum * weights, dirs)
    energy = np.einsum("hwc,hw->c", excess, weights)
    total = np.einsum("hwc,hw->c", px, weights)
    solid_angle = float(omega[ex_lum > 0.0].sum())
    return (direction / np.linalg.norm(direction), solid_angle, energy / solid_angle,
            (px - excess).astype(np.float32), energy / total)  # fmt: skip


class TestSameAsStraightforward:
    """The extraction (cached texel geometry, excess and residual on the cap only) gives the
    plain whole-map computation's numbers bit for bit."""

    @pytest.mark.parametrize("layout,shape", [("latlong", (64, 128)), ("cube-strip", (96, 16)),
                                              ("cross-h", (48, 64))])  # fmt: skip
    @pytest.mark.parametrize("radius", [3.0, 10.0])
    def test_bit_for_bit(self, layout, shape, radius):
        rng = np.random.default_rng(7)
        px = (0.2 + rng.random(shape + (3,))).astype(np.float32)
        px[~texels(layout, *shape)[2]] = 0.0
        px[shape[0] // 3, shape[1] // 2] = 4e3  # a hot texel and its neighbour
        px[shape[0] // 3, shape[1] // 2 + 1] = [900.0, 1200.0, 700.0]
        env = Environment(px, layout)
        sun, residual, report = extract_sun(env, radius_deg=radius)
        direction, solid_angle, radiance, pixels, fraction = _straightforward_sun(env, radius)
        assert report["extracted"]
        assert sun.direction.tobytes() == direction.tobytes()
        assert sun.solid_angle == solid_angle
        assert sun.radiance.tobytes() == radiance.tobytes()
        assert residual.pixels.dtype == np.float32
        assert residual.pixels.tobytes() == pixels.tobytes()
        assert report["energy_fraction"].tobytes() == fraction.tobytes()
        assert env.pixels.tobytes() == px.tobytes()  # the input map untouched


class TestTexelGeometry:
    def test_shared_read_only_and_exact(self):
        env = Environment(np.ones((32, 64, 3), np.float32), "latlong")
        for got, want in zip(env.texels(), texels("latlong", 32, 64), strict=True):
            assert got.tobytes() == want.tobytes() and not got.flags.writeable
        assert env.texels()[0] is Environment(env.pixels.copy(), "latlong").texels()[0]
        w = env.quadrature_weights()
        assert not w.flags.writeable
        assert w.tobytes() == np.repeat(fejer_row_weights(32, 64)[:, None], 64, 1).tobytes()
        with pytest.raises(ValueError):
            env.texels()[1][0, 0] = 1.0

    def test_large_maps_not_kept(self, monkeypatch):
        from shbake.envmap import environment

        monkeypatch.setattr(environment, "GEOMETRY_KEPT_TEXELS", 16 * 32 - 1)
        env = Environment(np.ones((16, 32, 3), np.float32), "latlong")
        first, second = env.texels(), env.texels()
        assert first[0] is not second[0] and not first[0].flags.writeable
        assert first[0].tobytes() == texels("latlong", 16, 32)[0].tobytes()
        assert env.quadrature_weights() is not env.quadrature_weights()
