"""The GGX reflection integrals ``E0`` and ``E1``: the ground truth of glossy probes.

Silvennoinen et al. (2025), eq. 6–8, with ``f_DV = D V`` (no Fresnel)::

    E0(v, n, α) = ∫ L(l) f_DV(v, n, l) (n·l) dl
    E1(v, n, α) = ∫ L(l) f_DV(v, n, l) (1 − v·h)^5 (n·l) dl

``α`` is the GGX width itself (Walter et al. 2007; Mitsuba 3's ``alpha``;
SPEC §1; perceptual roughness ``r`` maps as ``α = r²``, ``docs/CONVENTIONS.md``),
separable Smith ``G = G1(v) G1(l)`` (SPEC §4, as Mitsuba 3). Sampling
half vectors from the distribution of visible normals (Heitz 2018) has density
``p_B(l) = G1(v) D(h) / (4 n·v)`` and leaves ``f_DV (n·l) = p_B(l) G1(l)``.
The map is sampled too: texel ``j`` with probability ∝ luminance × solid
angle, uniformly inside it (density ``p_L``). ``N`` samples of each,
combined by the balance heuristic (Veach 1997), on a deterministic 2D
Fibonacci lattice::

    E0 ≈ (1/N) Σ_{l ∈ B ∪ L} L(l) G1(l) p_B(l) / (p_B(l) + p_L(l)) [n·l > 0],
    E1 adds (1 − v·h)^5.

The map's samples converge fast where a small bright source (a sun, a lamp)
dominates; the BRDF's where the lobe is sharp. ``L`` is the lat-long texel
holding ``l``, so as ``N → ∞`` the estimate converges to the exact integral
of the piecewise-constant map — the brute-force texel sum of
:mod:`shbake.reference.brdf_shading`.
"""

import numpy as np

from shbake.brdf.ggx import check_geometry, sample_light_at, view_g1, vndf_frame, vndf_terms_at
from shbake.brdf.sampling import surface_frame
from shbake.conventions import ROUGHNESS_MIN, check_samples
from shbake.envmap.importance import latlong_flat, light_distribution
from shbake.envmap.layouts import latlong_texel, latlong_texel_point
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.point_sets import fibonacci_square

ALPHA_MIN = ROUGHNESS_MIN**2
"""Smallest GGX width the integrals accept (perceptual roughness 0.02)."""


def check_alpha(alpha, count: int | None = None, name: str = "alpha") -> np.ndarray:
    """Refuse GGX widths outside ``[ALPHA_MIN, 1]`` (or non-finite) with a one-line
    :class:`ParameterError`; returns float64, broadcast to ``(count,)`` when given."""
    a = np.asarray(alpha, dtype=float)
    if not np.all(np.isfinite(a)) or np.any(a < ALPHA_MIN - 1e-15) or np.any(a > 1.0 + 1e-12):
        raise ParameterError(
            f"{name} (GGX width) must lie in [{ALPHA_MIN:g}, 1], got {np.ravel(a)[:4]}"
        )
    if count is not None:
        a = np.ascontiguousarray(np.broadcast_to(a, (count,)))
    return a


@jit
def _map_samples(square, cdf, height, width, texel, dirs):
    """The ``N`` map samples, the same for every integral of a call: sample ``k`` picks
    texel ``texel[k]`` by inverting ``cdf`` at ``square[k, 0]`` and the point ``dirs[k]``
    inside it (uniform in solid angle; ``square[k, 1]`` across the column)."""
    texels = cdf.shape[0]
    for k in range(square.shape[0]):
        u = square[k, 0]
        j = min(np.searchsorted(cdf, u, side="right"), texels - 1)
        lo = cdf[j - 1] if j > 0 else 0.0
        f = (u - lo) / (cdf[j] - lo) if cdf[j] > lo else 0.5
        texel[k] = j
        dirs[k, 0], dirs[k, 1], dirs[k, 2] = latlong_texel_point(
            j, min(max(f, 0.0), 1.0), square[k, 1], height, width
        )


@jit
def _integrate_mis(views, normals, alphas, square, pixels, height, width, texel, dirs, density,
                   out0, out1, b0, b1):  # fmt: skip
    """Balance-heuristic MIS of ``N`` visible-normal and ``N`` map samples (module docstring;
    the map's from :func:`_map_samples`, none for a black map)."""
    n = square.shape[0]
    mapped = texel.shape[0] > 0
    for t in range(b0, b1):
        nx, ny, nz = normals[t, 0], normals[t, 1], normals[t, 2]
        (tx, ty, tz), (bx, by, bz), v_loc = surface_frame(
            views[t, 0], views[t, 1], views[t, 2], nx, ny, nz
        )
        a0 = np.zeros(3)
        a1 = np.zeros(3)
        frame = vndf_frame(alphas[t], alphas[t], v_loc[0], v_loc[1], v_loc[2])
        g1v = view_g1(v_loc[0], v_loc[1], v_loc[2], alphas[t])
        for k in range(n):
            # the BRDF's sample
            lx, ly, lz, g1, g1_tail, p_brdf = sample_light_at(
                (tx, ty, tz), (bx, by, bz), (nx, ny, nz), v_loc, alphas[t], frame, g1v,
                square[k, 0], square[k, 1],
            )  # fmt: skip
            if g1 > 0.0:
                j = latlong_texel(lx, ly, lz, height, width)
                w = p_brdf / (p_brdf + density[j])
                for c in range(3):
                    a0[c] += w * g1 * pixels[j, c]
                    a1[c] += w * g1_tail * pixels[j, c]
            # the map's sample
            if not mapped:
                continue
            j = texel[k]
            lx, ly, lz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
            l_loc = (
                tx * lx + ty * ly + tz * lz,
                bx * lx + by * ly + bz * lz,
                nx * lx + ny * ly + nz * lz,
            )
            if l_loc[2] <= 0.0:
                continue
            p_brdf, g1, tail = vndf_terms_at(g1v, *v_loc, *l_loc, alphas[t])
            w = p_brdf / (p_brdf + density[j])
            for c in range(3):
                a0[c] += w * g1 * pixels[j, c]
                a1[c] += w * g1 * tail * pixels[j, c]
        for c in range(3):
            out0[t, c] = a0[c] / n
            out1[t, c] = a1[c] / n


def ggx_integrals(pixels, views, normals, alpha, samples: int = 4096):
    """``E0`` and ``E1``, each ``(T, 3)``, at ``T`` world-space ``(v, n, α)``.

    Parameters
    ----------
    pixels : (H, 2H, 3) lat-long radiance (finite, ≥ 0).
    views, normals : (T, 3) unit world directions with ``n·v > 0``; ``v`` points
        from the surface toward the viewer.
    alpha : scalar or (T,) GGX width ``α`` in ``[ALPHA_MIN, 1]`` (not perceptual).
    samples : visible-normal samples, and as many map samples, per integral.
    """
    v, n, _ = check_geometry(views, normals, 1.0)
    a = check_alpha(alpha, v.shape[0])
    flat, h, w = latlong_flat(pixels)
    samples = check_samples(samples)
    e0 = np.empty((v.shape[0], 3))
    e1 = np.empty((v.shape[0], 3))
    cdf, density = light_distribution(flat, h, w)
    square = fibonacci_square(samples)
    mapped = samples if cdf.shape[0] else 0
    texel, dirs = np.empty(mapped, np.int64), np.empty((mapped, 3))
    if mapped:
        _map_samples(square, cdf, h, w, texel, dirs)
    run_blocks(_integrate_mis, v.shape[0], v.shape[0] * samples * 400.0,
               v, n, a, square, flat, h, w, texel, dirs, density, e0, e1)  # fmt: skip
    return e0, e1
