"""Sphere lights (shbake/shading/sphere_light.py) against direct quadrature over the cap:
the closed form, its energy, its SH."""

import numpy as np
import pytest

from shbake.sh.basis import real_sh
from shbake.sh.point_sets import fibonacci_sphere, fibonacci_square
from shbake.shading.sphere_light import (
    cap_band_factors,
    lights_sh,
    sphere_lambert,
    sphere_power,
    sphere_tangent,
)

CAP_POINTS = 200_000
"""Fibonacci points over a cap: the quadrature's error is well under 1e-5 of ``E``."""


def cap_points(direction, radius: float, n: int = CAP_POINTS):
    """``n`` points uniform in solid angle over the cap of ``radius`` about ``direction``
    and the cap's solid angle."""
    u = fibonacci_square(n)
    z = 1.0 - u[:, 0] * (1.0 - np.cos(radius))
    s = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    local = np.stack([s * np.cos(2 * np.pi * u[:, 1]), s * np.sin(2 * np.pi * u[:, 1]), z], 1)
    d = np.asarray(direction, dtype=np.float64)
    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b = np.cross(d, a)
    b /= np.linalg.norm(b)
    return local @ np.stack([b, np.cross(d, b), d]), 2.0 * np.pi * (1.0 - np.cos(radius))


def quadrature_lambert(cos_theta: float, radius: float) -> float:
    """``∫_cap L max(0, n·ω) dω`` with ``L = 1/(π sin²σ)`` (unit irradiance head-on)."""
    theta = np.arccos(cos_theta)
    normal = np.array([np.sin(theta), 0.0, np.cos(theta)])
    pts, omega = cap_points([0.0, 0.0, 1.0], radius)
    return float(np.maximum(pts @ normal, 0.0).mean() * omega / (np.pi * np.sin(radius) ** 2))


class TestSphereLambert:
    @pytest.mark.parametrize("radius", [0.02, 0.2, 0.5, 1.0, 1.4])
    @pytest.mark.parametrize("where", [1.0, 0.6, 0.0, -0.6, -0.999])
    def test_equals_quadrature_over_the_cap(self, radius, where):
        """Above, across and below the horizon (``cos θ = where · sin σ``, the band where
        the cap is clipped, and fully lit)."""
        c = where * np.sin(radius) if abs(where) < 1.0 else 0.95
        got = float(sphere_lambert(c, radius))
        assert got == pytest.approx(quadrature_lambert(c, radius), abs=2e-5 * max(1.0, c))

    def test_point_and_edges(self):
        c = np.linspace(-1.0, 1.0, 2001)
        np.testing.assert_array_equal(sphere_lambert(c, 0.0), np.maximum(c, 0.0))
        r = 0.3
        above, below = np.sin(r) * (1 + 1e-9), -np.sin(r) * (1 + 1e-9)
        assert float(sphere_lambert(above, r)) == above and float(sphere_lambert(below, r)) == 0.0
        edge = np.sin(r) * np.array([1 - 1e-9, -1 + 1e-9])
        np.testing.assert_allclose(sphere_lambert(edge, r), [np.sin(r), 0.0], atol=1e-7)

    def test_tiny_radius_is_a_point(self):
        """No cancellation: within ``±σ`` of the horizon a radius of 1e-7 rad gives values of
        order 1e-7, between 0 and ``σ``, increasing."""
        c = np.linspace(-1e-7, 1e-7, 101)
        got = sphere_lambert(c, 1e-7)
        assert np.all(got >= 0.0) and np.all(got <= 1e-7 * (1 + 1e-6))
        assert np.all(np.diff(got) >= 0.0)
        assert float(sphere_lambert(0.0, 1e-7)) == pytest.approx(1e-7 / (1.5 * np.pi), rel=1e-6)

    def test_broadcasts(self):
        got = sphere_lambert(np.zeros((4, 1)), np.array([0.0, 0.1, 0.2]))
        assert got.shape == (4, 3) and got[0, 0] == 0.0 and got[0, 2] > got[0, 1] > 0.0


class TestSpherePower:
    def test_values(self):
        np.testing.assert_allclose(sphere_power([0.0, np.pi / 3, np.pi / 2]),
                                   [1.0, 4.0 / 3.0, 2.0])  # fmt: skip

    @pytest.mark.parametrize("radius", [0.0, 0.3, 1.2])
    def test_irradiance_integrates_to_pi_times_the_energy(self, radius):
        """``∫ E dn = π Φ`` over all normals (200 000 Fibonacci normals)."""
        d = np.array([0.36, 0.48, 0.8])
        mean = sphere_lambert(fibonacci_sphere(200_000) @ d, radius).mean()
        assert 4.0 * np.pi * mean == pytest.approx(np.pi * sphere_power(radius), rel=2e-5)


class TestSphereTangent:
    @pytest.mark.parametrize("radius", [0.05, 0.3, 0.52, 1.2])
    @pytest.mark.parametrize("where", [0.0, 0.5, 1.5, 3.0])
    def test_equals_quadrature_over_the_cap(self, radius, where):
        """``p ⟨sqrt(1 − (t·ω)²)⟩/π²`` over the cap's points, the tangent ``where · σ`` from
        its centre (inside the cap, at its rim, outside) and at 90° (``where`` 0 → t ⊥ d)."""
        angle = np.pi / 2 if where == 0.0 else where * radius
        t = np.array([np.sin(angle), 0.0, np.cos(angle)])
        pts, _ = cap_points([0.0, 0.0, 1.0], radius)
        want = sphere_power(radius) * np.sqrt(np.maximum(0.0, 1.0 - (pts @ t) ** 2)).mean()
        got = float(sphere_tangent(np.cos(angle), radius))
        assert got == pytest.approx(want / np.pi**2, rel=2e-6)

    def test_point_symmetry_and_tiny_radius(self):
        c = np.linspace(-1.0, 1.0, 401)
        np.testing.assert_allclose(sphere_tangent(c, 0.0), np.sqrt(1.0 - c * c) / np.pi**2,
                                   atol=1e-16)  # fmt: skip
        np.testing.assert_array_equal(sphere_tangent(c, 0.4), sphere_tangent(-c, 0.4))
        np.testing.assert_allclose(sphere_tangent(c, 1e-7), np.sqrt(1.0 - c * c) / np.pi**2,
                                   atol=1e-8)  # fmt: skip


class TestCapBandFactors:
    @pytest.mark.parametrize("radius", [1e-3, 0.25, 1.3])
    def test_equals_the_mean_of_legendre_over_the_cap(self, radius):
        from scipy.special import eval_legendre

        pts, _ = cap_points([0.0, 0.0, 1.0], radius)
        want = [eval_legendre(l, pts[:, 2]).mean() for l in range(9)]
        np.testing.assert_allclose(cap_band_factors(8, radius), want, atol=2e-6)

    def test_point_and_shape(self):
        np.testing.assert_array_equal(cap_band_factors(5, 0.0), np.ones(6))
        assert cap_band_factors(3, np.array([0.1, 0.2])).shape == (2, 4)


class TestLightsSh:
    def test_projects_the_caps(self):
        """Two caps (one a point) projected by quadrature over their points."""
        dirs = np.array([[0.0, 0.6, 0.8], [1.0, 0.0, 0.0]])
        irr = np.array([[1.0, 2.0, 3.0], [0.5, 0.5, 0.5]])
        radii = np.array([0.4, 0.0])
        pts, omega = cap_points(dirs[0], radii[0])
        radiance = irr[0] / (np.pi * np.sin(radii[0]) ** 2)
        want = (real_sh(pts, 6).mean(axis=0) * omega)[:, None] * radiance[None, :]
        want += real_sh(dirs[1:], 6)[0][:, None] * irr[1][None, :]
        np.testing.assert_allclose(lights_sh(dirs, irr, radii, 6), want, atol=1e-5)
