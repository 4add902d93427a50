"""Independent computations the tests compare shbake with (SPEC §5): a second SH library
(ducc0) and a brute-force quadrature, shared by the test files that need them."""

import ducc0
import numpy as np

from shbake.envmap.layouts import latlong_directions, latlong_solid_angles
from shbake.reference.irradiance import brute_force_irradiance
from shbake.sh.projection import fejer_row_weights
from shbake.sh.rotation import SHRotation
from tests.helpers import synth_latlong


def ducc0_project(img, lmax):
    """Projection by ducc0 with the same nodes and weights, converted per SPEC §5."""
    h, w, nc = img.shape
    theta = np.pi * (np.arange(h) + 0.5) / h
    out = np.zeros(((lmax + 1) ** 2, nc))
    for c in range(nc):
        alm = ducc0.sht.experimental.adjoint_synthesis(
            map=np.ascontiguousarray(img[:, :, c], dtype=np.float64).reshape(1, -1),
            theta=theta,
            lmax=lmax,
            spin=0,
            nphi=np.full(h, w, dtype=np.uintp),
            phi0=np.full(h, np.pi / w),
            ringstart=(np.arange(h) * w).astype(np.uintp),
            ringfactor=fejer_row_weights(h, w),
            nthreads=1,
        )[0]
        idx = 0
        for m in range(lmax + 1):
            for l in range(m, lmax + 1):
                a = alm[idx]
                idx += 1
                if m == 0:
                    out[l * (l + 1), c] = a.real
                else:
                    s = np.sqrt(2) * (-1) ** m
                    out[l * (l + 1) + m, c] = s * a.real
                    out[l * (l + 1) - m, c] = -s * a.imag
    # ducc0's frame (x', y', z') = (-d_z, d_x, d_y) is improper: T = -(proper rotation).
    T = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    parity = (-1.0) ** np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
    return SHRotation(-T, lmax).apply(out * parity[:, None], transpose=True)


def albedo_quadrature(brdf, v, n_theta=384, rows=64):
    """∫ f(s, v) s_z ds by GL(θ) × trapezoid(φ) on the hemisphere, θ split at the mirror.

    ``rows`` θ rows at a time (at 2048 × 8192 nodes the whole grid's arrays took 2.6× as long).
    """
    x, w = np.polynomial.legendre.leggauss(n_theta)
    theta = 0.25 * np.pi * (x + 1.0)
    wt = 0.25 * np.pi * w * np.sin(theta)
    n_phi = 4 * n_theta
    phi = 2 * np.pi * (np.arange(n_phi) + 0.5) / n_phi
    total = 0.0
    for i in range(0, n_theta, rows):
        st, ct = np.sin(theta[i : i + rows])[:, None], np.cos(theta[i : i + rows])[:, None]
        s = np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), ct), -1)
        s = s.reshape(-1, 3)
        weight = (wt[i : i + rows, None] * np.full(n_phi, 2 * np.pi / n_phi)).reshape(-1)
        total = total + weight @ (brdf.evaluate(s, v) * s[:, 2:3])
    return total


QUERIES = np.array([[0, 0, 1.0], [0, 1.0, 0], [0.6, -0.48, 0.64], [-1.0, 0, 0]])
"""Four normals (or tangents) the irradiance checks query: the poles, the equator, a generic one."""


def brute_force_of_synthetic_map(coeffs, h, tangent):
    """Brute-force (tangent) irradiance at :data:`QUERIES` of the ``h × 2h`` lat-long map whose
    pixels are ``Σ c_i y_i`` (:func:`tests.helpers.synth_latlong`)."""
    img = synth_latlong(coeffs, h)
    d = latlong_directions(h, 2 * h).reshape(-1, 3)
    w = latlong_solid_angles(h, 2 * h).ravel()
    return brute_force_irradiance(d, w, img.reshape(-1, 3), QUERIES, tangent=tangent)
