"""Compact lights fitted to irradiance: ``K`` directional lights plus an SH residual (issue 33).

Engines take little for diffuse lighting: 9 SH coefficients per channel and a few
punctual lights. This module chooses both **by least squares on the irradiance**, not
by projecting radiance. The model, at a unit normal ``n``::

    E(n) = Σ_i e_i y_i(n) + Σ_k a_k max(0, n·d_k)

(``--light-shape sphere``: ``max(0, n·d_k)`` becomes a sphere light's horizon-clipped
:func:`~shbake.shading.sphere_light.sphere_lambert` of angular radius ``σ_k``, fitted too.)

``e_i``: irradiance SH (``Â_l`` folded in, SPEC §4) of bands ``l ≤ irradiance lmax``
where ``Â_l ≠ 0`` (``l = 0, 1`` and even ``l``); ``d_k``: unit direction toward light
``k``; ``a_k`` (RGB, ``≥ 0``): its irradiance at normal incidence. The target is the
brute-force irradiance of the map (:func:`shbake.reference.irradiance.brute_force_irradiance`)
at :data:`FIT_DIRECTIONS` spherical-Fibonacci normals; each residual is divided by the
target's luminance there, so the fit minimises the *relative* error (RMS over normals,
per channel).

Constraints:

* **energy**: ``∫ E dn = π ∫ L dω`` holds exactly, so nothing is lost between the lights
  and the residual. With ``∫ max(0, n·d) dn = π`` and ``∫ y_0 dn = 2√π`` this fixes
  ``e_0 = (Φ − Σ_k p_k a_k) √π / 2`` (``Φ = ∫ L dω`` per channel, the brute force's own
  sum; ``p_k`` a light's energy per unit ``a_k``: 1 for a point,
  :func:`~shbake.shading.sphere_light.sphere_power` for a sphere); the lights enter as
  zero-mean lobes ``max(0, n·d) − p/4`` against the fixed constant ``Φ/4``.
* ``a_k ≥ 0`` (NNLS for the intensities once the SH columns are projected out: variable
  projection, so the outer search sees only the ``2K`` direction angles, and the ``K``
  radii of spheres);
* the **SH part alone is never negative**: a light an engine shadows leaves the SH,
  which must still be a valid irradiance. It is checked at :data:`CHECK_DIRECTIONS`
  normals (16× denser than the fit's); when the unconstrained optimum breaks it, the
  linear parameters are solved again as a quadratic programme (SLSQP, directions kept)
  with ``SH part ≥ m Φ/4`` at the fit normals, the margin ``m`` growing through
  :data:`NONNEGATIVE_MARGINS` until the dense check passes (a polynomial constrained only
  at points may dip between them).

Directions (and sphere radii, up to :data:`MAX_RADIUS_DEG`) are searched by
``scipy.optimize.least_squares`` (trust region) from several starts: each ``K`` keeps
the ``K − 1`` lights found and adds one at each of the map's brightest coarse cells
(:data:`MAP_STARTS`) and at the fit normals where the ``K − 1`` fit falls furthest short
(:data:`RESIDUAL_STARTS`); spheres also start from the ``K`` points' optimum. The fit
whose cost is least once its SH part is held non-negative wins, not the least optimum
before that: on night two spheres' least optimum (a radius at :data:`MAX_RADIUS_DEG`) cost
more than the points once held, while the next (radii 12.5° and 12.9°) cost less, and which
of the two came first turned on rounding (CPUs with and without AVX-512). Optima are held
in order of their cost and the search stops at one that already costs more than the best
held fit, since holding never lowers a cost.
:func:`choose_lights` takes the fewest lights (``0 … max``) whose mean relative
luminance error on the fit normals is at most the tolerance.
"""

from typing import NamedTuple

import numpy as np

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap.environment import Environment
from shbake.errors import ParameterError
from shbake.reference.irradiance import brute_force_irradiance
from shbake.sh.basis import real_sh
from shbake.sh.kernels import lambert_kernel
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.sphere_light import sphere_lambert, sphere_power

FIT_DIRECTIONS = 4096
"""Spherical-Fibonacci normals (:func:`~shbake.sh.point_sets.fibonacci_sphere`) the fit
and its tolerance are measured at (a different lattice from the 2048 of the benchmarks)."""
FIT_ROWS = 256
"""A map with more texels than ``FIT_ROWS × 2 FIT_ROWS`` is binned into that many
lat-long cells (radiance × solid angle summed, directions averaged) before the
brute-force target: its error is second order in the cell size (0.7°)."""
MAX_LIGHTS = 8
"""Most lights ``--lights K`` takes."""
AUTO_MAX_LIGHTS = 3
"""Most lights ``--lights auto`` tries: the handful of punctual lights engines afford."""
MAP_STARTS = 6
"""Brightest coarse map cells (11.25°) tried as the start of a new light."""
RESIDUAL_STARTS = 3
"""Fit normals where the fit with one light fewer falls furthest short, tried likewise."""
START_SEPARATION_DEG = 15.0
"""Starts closer than this to a better one are dropped."""
CHECK_DIRECTIONS = 65536
"""Fibonacci normals at which the SH part is checked to be non-negative."""
NONNEGATIVE_MARGINS = (1e-3, 4e-3, 1.6e-2, 6.4e-2)
"""Margins ``m`` (fractions of the mean irradiance ``Φ/4``) the constrained solve tries."""
SHAPES = ("point", "sphere")
"""Light shapes: ``point`` (directional, what every engine export takes) or ``sphere``
(a uniform cap of fitted angular radius, shbake's own shaders)."""
MAX_RADIUS_DEG = 30.0
"""Largest angular radius of a fitted sphere light, degrees."""
SPHERE_EVALUATIONS = 30
"""Least-squares evaluations per parameter a sphere search may take (scipy's default: 100).
On a half-black map the radii drift along a flat valley (two spheres took 41 s, 15 s
with the cap); the six sample maps' fits converge within it, to the same lights."""
START_RADIUS_DEG = 5.0
"""Angular radius a new sphere light starts from (a point's gradient in ``σ`` is 0)."""
LIGHT_FLOOR = 1e-12
"""A fitted light whose luminous energy is at most this fraction of the map's is round-off of
the intensities' solve, not a light: dropped (a one-texel map × 1e-30 got a second light of
1.6e-17 of its energy, where the same map × 1 got none)."""
WEIGHT_FLOOR = 1e-6
"""Target luminance below this fraction of its largest value is weighted, and its relative
error measured, as this fraction (a black hemisphere would otherwise get infinite weight,
and an error of 1e300)."""


class IrradianceTarget(NamedTuple):
    """Brute-force irradiance of a map at the fit normals.

    ``normals`` (N, 3); ``irradiance`` (N, 3) RGB; ``energy`` (3,) ``Φ = ∫ L dω`` by the
    same quadrature; ``coarse`` ``(directions (M, 3), luminous energy (M,))`` of the
    map's coarse cells, the starts of new lights.
    """

    normals: np.ndarray
    irradiance: np.ndarray
    energy: np.ndarray
    coarse: tuple


class LightFit(NamedTuple):
    """``K`` lights and the irradiance SH of the residual, with the fit's errors.

    ``directions`` (K, 3) unit, toward the lights; ``irradiance`` (K, 3) at normal
    incidence; ``radii`` (K,) angular radii in radians (0: points); ``sh`` ((lmax+1)², 3)
    irradiance SH ``e_i`` (zero where ``Â_l = 0``);
    errors: relative luminance error on the fit normals (``mean``, ``max``) and the
    relative RMS ``sqrt(Σ (Y − Y_ref)² / Σ Y_ref²)`` (the scene tolerance's measure).
    """

    directions: np.ndarray
    irradiance: np.ndarray
    radii: np.ndarray
    sh: np.ndarray
    mean_error: float
    max_error: float
    rms_error: float

    @property
    def count(self) -> int:
        return int(self.directions.shape[0])


def _binned_samples(env: Environment, rows: int):
    """``(dirs, solid angles, radiance)`` of the map, binned into ``rows × 2 rows`` lat-long
    cells when it has more texels (energy and the energy-weighted direction kept)."""
    dirs, omega, radiance = env.samples()
    if dirs.shape[0] <= 2 * rows * rows:
        return dirs, omega, radiance
    v = np.arccos(np.clip(dirs[:, 1], -1.0, 1.0)) / np.pi
    u = np.mod(np.arctan2(dirs[:, 0], -dirs[:, 2]) / (2.0 * np.pi), 1.0)
    cell = np.minimum((v * rows).astype(np.int64), rows - 1) * (2 * rows) + np.minimum(
        (u * 2 * rows).astype(np.int64), 2 * rows - 1
    )
    n = 2 * rows * rows
    om = np.bincount(cell, omega, n)
    lw = np.stack([np.bincount(cell, radiance[:, c] * omega, n) for c in range(3)], axis=1)
    dw = np.stack([np.bincount(cell, dirs[:, k] * omega, n) for k in range(3)], axis=1)
    keep = om > 0.0
    d = dw[keep] / np.linalg.norm(dw[keep], axis=1, keepdims=True)
    return d, om[keep], lw[keep] / om[keep, None]


def _coarse_cells(dirs, omega, radiance, rows: int = 16):
    """Luminous energy and energy-weighted direction of ``rows × 2 rows`` lat-long cells."""
    v = np.arccos(np.clip(dirs[:, 1], -1.0, 1.0)) / np.pi
    u = np.mod(np.arctan2(dirs[:, 0], -dirs[:, 2]) / (2.0 * np.pi), 1.0)
    cell = np.minimum((v * rows).astype(np.int64), rows - 1) * (2 * rows) + np.minimum(
        (u * 2 * rows).astype(np.int64), 2 * rows - 1
    )
    lum = np.maximum(radiance @ REC709_LUMINANCE, 0.0) * omega
    n = 2 * rows * rows
    e = np.bincount(cell, lum, n)
    dw = np.stack([np.bincount(cell, dirs[:, k] * lum, n) for k in range(3)], axis=1)
    keep = e > 0.0
    return dw[keep] / np.linalg.norm(dw[keep], axis=1, keepdims=True), e[keep]


def irradiance_target(env: Environment, n_dirs: int = FIT_DIRECTIONS) -> IrradianceTarget:
    """Brute-force irradiance of ``env`` at ``n_dirs`` Fibonacci normals.

    Cost ``O(texels × n_dirs)`` after binning to at most ``2 FIT_ROWS²`` cells (about
    0.5 s per core for 131 072 texels × 4096 normals).
    """
    dirs, omega, radiance = _binned_samples(env, FIT_ROWS)
    normals = fibonacci_sphere(n_dirs)
    target = brute_force_irradiance(dirs, omega, radiance, normals)
    energy = np.einsum("nc,n->c", radiance, omega)
    return IrradianceTarget(normals, target, energy, _coarse_cells(dirs, omega, radiance))


def fitted_bands(lmax: int) -> np.ndarray:
    """Indices ``i ≥ 1`` of the SH coefficients the fit solves for (``Â_l ≠ 0``)."""
    kernel = lambert_kernel(lmax)
    return np.array([i for i in range(1, (lmax + 1) ** 2) if kernel[int(np.sqrt(i))] != 0.0],
                    dtype=np.intp)


def _frames(starts: np.ndarray) -> np.ndarray:
    """Per start direction ``s`` a rotation ``R`` with ``R (1, 0, 0) = s``: the angles
    ``(θ, φ) = (π/2, 0)`` start there, 90° from the parameterisation's poles."""
    out = np.empty((len(starts), 3, 3))
    for k, s in enumerate(starts):
        a = np.array([0.0, 0.0, 1.0]) if abs(s[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        b = np.cross(s, a)
        b /= np.linalg.norm(b)
        out[k] = np.stack([s, b, np.cross(s, b)], axis=1)
    return out


def _directions(angles: np.ndarray, frames: np.ndarray) -> np.ndarray:
    th, ph = angles[0::2], angles[1::2]
    local = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=1)
    return np.einsum("kij,kj->ki", frames, local)


class _Problem:
    """The weighted linear algebra shared by every direction set of one fit."""

    def __init__(self, target: IrradianceTarget, lmax: int, extra_weight=None):
        """``extra_weight`` (N,): a factor on each normal's residual besides ``1/Y``
        (``bench/irradiance_lights.py`` reweights toward the mean relative error)."""
        self.target = target
        self.lmax = lmax
        self.bands = fitted_bands(lmax)
        y = target.irradiance @ REC709_LUMINANCE
        self.lum = y
        self.floored = np.maximum(y, WEIGHT_FLOOR * max(float(y.max()), 1e-300))
        self.w = 1.0 / self.floored
        if extra_weight is not None:
            self.w = self.w * extra_weight
        self.Y = real_sh(target.normals, lmax)[:, self.bands]
        self.T = (target.irradiance - target.energy[None, :] / 4.0) * self.w[:, None]
        Yw = self.Y * self.w[:, None]
        self.Yw = Yw
        self.Qy = np.linalg.qr(Yw)[0] if Yw.shape[1] else np.zeros((len(y), 0))
        self.pinv = np.linalg.pinv(Yw) if Yw.shape[1] else np.zeros((0, len(y)))
        self.Tp = self.T - self.Qy @ (self.Qy.T @ self.T)

    def lobes(self, dirs: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """Zero-mean lobes ``K(n·d) − p/4`` at the fit normals, ``(N, K)`` (module
        docstring; ``radii`` 0: ``max(0, n·d) − 1/4``, the search's inner loop for points)."""
        c = self.target.normals @ dirs.T
        if not radii.any():
            return np.maximum(c, 0.0) - 0.25
        return sphere_lambert(c, radii[None, :]) - sphere_power(radii)[None, :] / 4.0

    def linear(self, dirs: np.ndarray, radii: np.ndarray):
        """``(e (bands, 3), a (K, 3))`` minimising the weighted residual, ``a ≥ 0``."""
        from scipy.optimize import nnls

        Cw = self.lobes(dirs, radii) * self.w[:, None]
        a = np.zeros((len(dirs), 3))
        if len(dirs):
            Cp = Cw - self.Qy @ (self.Qy.T @ Cw)
            for c in range(3):
                a[:, c] = nnls(Cp, self.Tp[:, c])[0]
        e = self.pinv @ (self.T - Cw @ a)
        return e, a

    def residual(self, dirs, radii, e, a) -> np.ndarray:
        """Weighted residuals ``(N, 3)``."""
        return self.Yw @ e + (self.lobes(dirs, radii) * self.w[:, None]) @ a - self.T

    def sh_minimum(self, radii, e, a) -> float:
        """The SH part's smallest value over the channels at :data:`CHECK_DIRECTIONS`
        normals, relative to its mean ``(Φ − Σ p a)/4`` (1 for a black map)."""
        mean = (self.target.energy - sphere_power(radii) @ a) / 4.0
        if float(mean.max()) <= 0.0:
            return 1.0
        low = (mean[None, :] + real_sh(fibonacci_sphere(CHECK_DIRECTIONS), self.lmax)[:, self.bands]
               @ e).min(axis=0)  # fmt: skip
        return float(np.min(low / np.where(mean > 0.0, mean, 1.0)))

    def constrained(self, dirs, radii, e, a, margin: float):
        """Solve the linear parameters again with ``SH part ≥ margin Φ/4`` at the fit
        normals and ``a ≥ 0`` (SLSQP).

        Each channel is solved in units of its mean irradiance ``|Φ_c|/4`` (1 for a black
        channel): the unknowns (``e``, ``a``), the constraint (``SH part ≥ margin`` in those
        units) and the objective (residuals relative to the target, over their largest) are
        then free of the map's scale, as SLSQP needs (its tolerance is absolute and its first
        step a unit one). In the map's own units it could not meet the tolerance on a map
        × 1e30 (200 steps a solve, the SH part still negative: ``--lights 3`` on a black map
        with two texels of 1e30 took 136 s, 1.6 s in these units) and gave up at once on a map
        × 1e-30 (its SH off by 1e34)."""
        from scipy.optimize import minimize

        Cw = self.lobes(dirs, radii) * self.w[:, None]
        A = np.hstack([self.Yw, Cw])
        nb, k = self.Y.shape[1], len(dirs)
        G = np.hstack([self.Y, -np.tile(sphere_power(radii) / 4.0, (len(self.w), 1))])
        e2, a2 = e.copy(), a.copy()
        for c in range(3):
            mean = float(self.target.energy[c]) / 4.0
            unit = abs(mean) or 1.0
            h = mean / unit * (1.0 - margin)
            x0 = np.concatenate([e[:, c], a[:, c]]) / unit
            scale = max(float(np.abs(self.T[:, c]).max()), 1e-300)
            t = self.T[:, c] / scale
            As = A * (unit / scale)
            res = minimize(
                lambda x, As=As, t=t: float(np.sum((As @ x - t) ** 2)),
                x0,
                jac=lambda x, As=As, t=t: 2.0 * As.T @ (As @ x - t),
                method="SLSQP",
                bounds=[(None, None)] * nb + [(0.0, None)] * k,
                constraints=[
                    {"type": "ineq", "fun": lambda x, h=h: G @ x + h, "jac": lambda x: G}
                ],  # fmt: skip
                options={"maxiter": 200, "ftol": 1e-12},
            )
            x = res.x * unit
            e2[:, c], a2[:, c] = x[:nb], np.maximum(x[nb:], 0.0)
        return e2, a2

    def cost(self, fit: LightFit) -> float:
        """The weighted least-squares cost (the search's objective) of a finished fit."""
        r = self.residual(fit.directions, fit.radii, fit.sh[self.bands], fit.irradiance)
        return float(np.sum(r**2))

    def result(self, dirs, radii, e, a) -> LightFit:
        total = max(float(self.target.energy @ REC709_LUMINANCE), 0.0)
        keep = sphere_power(radii) * (a @ REC709_LUMINANCE) > LIGHT_FLOOR * total
        dirs, radii, a = dirs[keep], radii[keep], a[keep]
        order = np.argsort(-(a @ REC709_LUMINANCE), kind="stable")
        dirs, radii, a = dirs[order], radii[order], a[order]
        sh = np.zeros(((self.lmax + 1) ** 2, 3))
        sh[0] = (self.target.energy - sphere_power(radii) @ a) * np.sqrt(np.pi) / 2.0
        sh[self.bands] = e
        model = self.Y @ e + sphere_lambert(self.target.normals @ dirs.T, radii[None, :]) @ a
        model += sh[0][None, :] / (2.0 * np.sqrt(np.pi))
        got = model @ REC709_LUMINANCE
        rel = np.abs(got - self.lum) / self.floored  # relative to the weights' floor
        rms = np.sqrt(np.sum((got - self.lum) ** 2) / max(float(np.sum(self.lum**2)), 1e-300))
        return LightFit(dirs, a, radii, sh, float(rel.mean()), float(rel.max()), float(rms))


def _search(problem: _Problem, starts: np.ndarray, start_radii: np.ndarray | None):
    """Directions (K, 3), radii (K,) and the cost of the least-squares optimum from
    ``starts``; ``start_radii`` ``None``: point lights (radii 0, not searched)."""
    from scipy.optimize import least_squares

    frames = _frames(starts)
    k = len(starts)
    spheres = start_radii is not None

    def unpack(x):
        return _directions(x[: 2 * k], frames), x[2 * k:] if spheres else np.zeros(k)

    def fun(x):
        dirs, radii = unpack(x)
        return problem.residual(dirs, radii, *problem.linear(dirs, radii)).ravel()

    x0 = np.tile([np.pi / 2.0, 0.0], k)
    lower, upper = np.full(2 * k, -np.inf), np.full(2 * k, np.inf)
    if spheres:
        top = np.radians(MAX_RADIUS_DEG)
        x0 = np.concatenate([x0, np.clip(start_radii, 0.0, top)])
        lower = np.concatenate([lower, np.zeros(k)])
        upper = np.concatenate([upper, np.full(k, top)])
    budget = {"max_nfev": SPHERE_EVALUATIONS * len(x0)} if spheres else {}
    res = least_squares(fun, x0, method="trf", x_scale=0.1, diff_step=1e-4, bounds=(lower, upper),
                        **budget)  # fmt: skip
    return *unpack(res.x), float(np.sum(res.fun**2))


def _new_light_starts(problem: _Problem, previous: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Starts for one more light: bright map cells and the largest shortfalls of the lights
    ``previous`` (of angular ``radii``)."""
    cells, energy = problem.target.coarse
    picks = list(cells[np.argsort(-energy, kind="stable")])
    e, a = problem.linear(previous, radii)
    short = -(problem.residual(previous, radii, e, a) @ REC709_LUMINANCE)
    by_short = problem.target.normals[np.argsort(-short, kind="stable")]
    out: list[np.ndarray] = []
    cos_sep = np.cos(np.radians(START_SEPARATION_DEG))
    for pool, limit in ((picks, MAP_STARTS), (by_short, RESIDUAL_STARTS)):
        taken = 0
        for d in pool:
            if taken == limit:
                break
            if all(float(d @ o) < cos_sep for o in out):
                out.append(d)
                taken += 1
    return np.array(out).reshape(-1, 3)


def fit_lights(target: IrradianceTarget, count: int, lmax: int = 2,
               previous: LightFit | None = None, shape: str = "point",
               points: LightFit | None = None) -> LightFit:  # fmt: skip
    """The best fit with ``count`` lights (fewer if the optimum turns some off).

    ``previous``: a fit with ``count − 1`` lights of the same ``shape`` to build on (found
    here when omitted); ``shape``: one of :data:`SHAPES`. Spheres also start from the
    directions of the fit with ``count`` ``points`` (found here when omitted), every radius
    :data:`START_RADIUS_DEG`; and since a sphere of radius 0 is a point, that fit is
    returned when its weighted least-squares cost (after the SH part is held non-negative,
    which can cost a sphere fit more than the points') is the lower.
    """
    if not 0 <= count <= MAX_LIGHTS:
        raise ParameterError(f"number of lights must be in 0…{MAX_LIGHTS}, got {count}")
    if shape not in SHAPES:
        raise ParameterError(f"light shape must be one of {', '.join(SHAPES)}, got {shape!r}")
    problem = _Problem(target, lmax)
    if count > 0 and previous is None:
        previous = fit_lights(target, count - 1, lmax, shape=shape)
    dirs, radii, fit = np.zeros((0, 3)), np.zeros(0), None
    if count > 0 and float(np.max(target.energy)) > 0.0:
        starts = [(np.vstack([previous.directions, s[None, :]]),
                   np.append(previous.radii, np.radians(START_RADIUS_DEG)))
                  for s in _new_light_starts(problem, previous.directions, previous.radii)]
        if shape == "sphere":
            if points is None:
                points = fit_lights(target, count, lmax)
            if points.count:
                start_radius = np.radians(START_RADIUS_DEG)
                starts.append((points.directions, np.full(points.count, start_radius)))
        found = sorted((_search(problem, d, r if shape == "sphere" else None) for d, r in starts),
                       key=lambda f: f[2])  # fmt: skip
        least = np.inf
        for dirs, radii, cost in found:
            if cost >= least:
                break  # holding the SH part non-negative never lowers a cost
            finished = _finish(problem, dirs, radii)
            held = problem.cost(finished)
            if fit is None or held < least:
                fit, least = finished, held
    if fit is None:
        fit = _finish(problem, dirs, radii)
    if points is not None and problem.cost(points) <= problem.cost(fit):
        return points
    return fit


def _finish(problem: _Problem, dirs: np.ndarray, radii: np.ndarray) -> LightFit:
    """The fit with lights ``dirs`` of angular ``radii``: linear parameters solved, then
    solved again with the SH part held non-negative (:data:`NONNEGATIVE_MARGINS`) where it
    dips below zero."""
    e, a = problem.linear(dirs, radii)
    if problem.sh_minimum(radii, e, a) < 0.0:
        for margin in NONNEGATIVE_MARGINS:
            e, a = problem.constrained(dirs, radii, e, a, margin)
            if problem.sh_minimum(radii, e, a) >= 0.0:
                break
    return problem.result(dirs, radii, e, a)


def light_chain(target: IrradianceTarget, max_count: int, lmax: int = 2, shape: str = "point"):
    """The fits with ``0 … max_count`` lights, each built on the one before (spheres beside
    the points' own chain, which they also start from): what :func:`fit_lights` finds
    alone, without fitting the shorter chains again."""
    previous = points = None
    for k in range(max_count + 1):
        if shape == "sphere":
            points = fit_lights(target, k, lmax, points)
        previous = fit_lights(target, k, lmax, previous, shape, points)
        yield previous


def choose_lights(
    target: IrradianceTarget,
    tol: float,
    max_count: int = AUTO_MAX_LIGHTS,
    lmax: int = 2,
    measure: str = "mean_error",
    shape: str = "point",
) -> tuple[LightFit, list[LightFit]]:
    """The fit with the fewest lights (``0 … max_count``, of ``shape``) whose ``measure`` (a
    :class:`LightFit` error: ``mean_error`` by default, ``rms_error`` for scene
    tolerances) is at most ``tol``, else the one with the lowest; and every fit tried."""
    if not 0.0 < tol < 1.0:
        raise ParameterError(f"light tolerance must be in (0, 1), got {tol}")
    tried: list[LightFit] = []
    for k, fit in enumerate(light_chain(target, max_count, lmax, shape)):
        tried.append(fit)
        if getattr(fit, measure) <= tol:
            return fit, tried
        if fit.count < k:  # the optimum turned a light off: more starts find no more
            break
    return min(tried, key=lambda f: getattr(f, measure)), tried


__all__ = [
    "AUTO_MAX_LIGHTS",
    "FIT_DIRECTIONS",
    "IrradianceTarget",
    "LightFit",
    "MAX_LIGHTS",
    "MAX_RADIUS_DEG",
    "SHAPES",
    "choose_lights",
    "fit_lights",
    "fitted_bands",
    "irradiance_target",
    "light_chain",
]
