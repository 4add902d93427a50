"""Sun extraction on synthetic maps with a known light."""

import numpy as np
import pytest

from shbake.envmap import Environment
from shbake.envmap.layouts import latlong_directions, latlong_solid_angles
from shbake.envmap.sun import extract_sun
from shbake.errors import ParameterError


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
