"""Spherical-harmonic exponential glossy probes (Silvennoinen et al. 2025, §4).

``E0(v, n, r) ≈ P(ρ, r) Q(h_ρ, r)`` (eq. 9–11) with ``ρ = 2(n·v)n − v`` the
mirror direction, ``h_ρ = (n + ρ)/|n + ρ|``, and::

    P = exp(Σ_lm vMF_l(1/r) y_lm(ρ) p_lm),  Q = exp(Σ_lm vMF_l(1/r) y_lm(h_ρ) q_lm)
    vMF_l(κ) = exp(−l(l+1)/(2κ))                                    (eq. 12)

``p``: ``lmax_p`` (default 4, 25 coefficients); ``q``: ``lmax_q`` (default 2)
without its DC term (8), which ``p`` already holds (§4.1). ``r`` is the
paper's α, read as perceptual roughness (GGX width ``r²``, CONVENTIONS).
The fit (eq. 13–14) is linear least squares in log space over fixed
``(v, n, r)`` samples; everything but the right-hand side is built once
(:class:`FitPlan`). Full radiance: ``E = F0 E0 + (1 − F0) E0 A1/A0``
(eq. 5, 15; :mod:`shbake.probe.albedo_table`).
"""

from dataclasses import asdict, dataclass

import numba
import numpy as np
import scipy.linalg

from shbake.brdf.sampling import tangent_frame
from shbake.conventions import n_coeffs
from shbake.errors import ParameterError
from shbake.jit import jit, pjit
from shbake.probe.albedo_table import table_lookup
from shbake.probe.ggx_integrals import QuadraturePlan, check_roughness, fibonacci_square
from shbake.probe.sh_targets import LMAX_LIMIT, ShTargets
from shbake.sh.basis import real_sh, recurrence_tables, sh_eval_into
from shbake.sh.windows import fibonacci_sphere

WEIGHTINGS = ("log", "relative", "linear")
TARGETS = ("quadrature", "sh")
GAUSS_NEWTON_STEPS = 4
STEP_HALVINGS = 12
ABSOLUTE_FLOOR = 1e-30


@dataclass(frozen=True)
class FitConfig:
    """Everything that shapes a fit; two probes fitted with equal configs are comparable.

    ``floor``: ``E0`` below ``floor × mean(E0)`` (per channel, and below
    ``1e-30``) is raised to it before the log, so dark and black maps stay
    finite. ``weighting``: ``log`` minimises the log residual (eq. 13, a
    proxy of relative error); ``relative`` continues with damped Gauss–Newton
    steps on the relative error ``PQ/E0 − 1`` itself, ``linear`` on the linear
    error ``(PQ − E0)/mean(E0)`` (what an MSE weighs: bright targets
    dominate). ``targets``: how ``E0`` is computed at the fit samples —
    ``quadrature`` (``samples`` filtered visible-normal samples each) or
    ``sh`` (SH lighting to ``targets_lmax`` × GGX tables,
    :mod:`shbake.probe.sh_targets`).
    """

    lmax_p: int = 4
    lmax_q: int = 2
    normals: int = 64
    views: int = 64
    roughness_count: int = 4
    roughness_min: float = 0.2
    roughness_max: float = 1.0
    samples: int = 1024
    weighting: str = "log"
    floor: float = 1e-4
    targets: str = "quadrature"
    targets_lmax: int = 8

    def __post_init__(self):
        checks = [
            (0 <= self.lmax_p <= 8, "lmax_p must be in [0, 8]"),
            (1 <= self.lmax_q <= 8, "lmax_q must be in [1, 8]"),
            (4 <= self.normals <= 4096, "normals must be in [4, 4096]"),
            (4 <= self.views <= 4096, "views must be in [4, 4096]"),
            (1 <= self.roughness_count <= 64, "roughness_count must be in [1, 64]"),
            (self.weighting in WEIGHTINGS, f"weighting must be one of {', '.join(WEIGHTINGS)}"),
            (np.isfinite(self.floor) and 0 < self.floor < 1, "floor must be in (0, 1)"),
            (self.targets in TARGETS, f"targets must be one of {', '.join(TARGETS)}"),
            (1 <= self.targets_lmax <= LMAX_LIMIT, f"targets_lmax must be in [1, {LMAX_LIMIT}]"),
        ]
        for ok, msg in checks:
            if not ok:
                raise ParameterError(msg)
        check_roughness([self.roughness_min, self.roughness_max], 0.05, 1.0, "roughness range")
        if self.roughness_min > self.roughness_max or (
            self.roughness_count > 1 and self.roughness_min == self.roughness_max
        ):
            raise ParameterError("roughness range must be lo < hi (or one value with count 1)")

    @property
    def roughness(self) -> np.ndarray:
        return np.linspace(self.roughness_min, self.roughness_max, self.roughness_count)

    @property
    def n_params(self) -> int:
        return n_coeffs(self.lmax_p) + n_coeffs(self.lmax_q) - 1

    def as_dict(self) -> dict:
        return asdict(self)


def vmf_factors(lmax: int, roughness) -> np.ndarray:
    """``vMF_l(1/r)`` per coefficient index, shape ``(…, (lmax+1)^2)`` (eq. 12)."""
    l = np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
    r = np.asarray(roughness, dtype=float)[..., None]
    return np.exp(-l * (l + 1) * r / 2.0)


def hemisphere_fibonacci(n: int) -> np.ndarray:
    """``n`` local directions spread uniformly over the upper hemisphere (``z`` uniform)."""
    u = fibonacci_square(n)
    z = 1.0 - u[:, 0]
    s = np.sqrt(1.0 - z * z)
    phi = 2.0 * np.pi * u[:, 1]
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], 1)


def mirror_and_half(views, normals) -> tuple[np.ndarray, np.ndarray]:
    """``ρ = 2(n·v)n − v`` and ``h_ρ = (n + ρ)/|n + ρ|`` (eq. 10)."""
    nv = np.einsum("...i,...i->...", normals, views)[..., None]
    rho = 2.0 * nv * normals - views
    h = normals + rho
    return rho, h / np.linalg.norm(h, axis=-1, keepdims=True)


def design_rows(views, normals, roughness, lmax_p: int, lmax_q: int) -> np.ndarray:
    """Rows of eq. 14: ``[vMF ⊙ Y(ρ), (vMF ⊙ Y(h_ρ)) without DC]``, ``(T, n_params)``."""
    rho, h = mirror_and_half(views, normals)
    yp = real_sh(rho, lmax_p) * vmf_factors(lmax_p, roughness)
    yq = real_sh(h, lmax_q) * vmf_factors(lmax_q, roughness)
    return np.concatenate([yp, yq[:, 1:]], axis=1)


@jit
def _normal_matrix(A, w, out):
    """``out = Aᵀ diag(w) A`` with a fixed summation order (deterministic)."""
    n = A.shape[1]
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for t in range(A.shape[0]):
                s += A[t, i] * w[t] * A[t, j]
            out[i, j] = s
            out[j, i] = s


@jit
def _weighted_rhs(A, w, b, out):
    """``out = Aᵀ diag(w) b`` per column of ``b`` (deterministic order)."""
    for c in range(b.shape[1]):
        for i in range(A.shape[1]):
            s = 0.0
            for t in range(A.shape[0]):
                s += A[t, i] * w[t] * b[t, c]
            out[i, c] = s


def _factor(A, w):
    """Cholesky factor of the column-scaled normal matrix ``D Aᵀ diag(w) A D``, and ``D``."""
    m = np.empty((A.shape[1], A.shape[1]))
    _normal_matrix(A, w, m)
    d = 1.0 / np.sqrt(np.maximum(np.diag(m), 1e-300))
    return scipy.linalg.cho_factor(m * d[:, None] * d[None, :], lower=True), d


def _solve(A, w, b, factor=None):
    """Weighted least squares ``argmin ||diag(√w)(A x − b)||²`` by the normal equations
    (``factor`` from :func:`_factor` of the same ``A, w`` when reused)."""
    cho, d = factor if factor is not None else _factor(A, w)
    rhs = np.empty((A.shape[1], b.shape[1]))
    _weighted_rhs(A, w, b, rhs)
    return scipy.linalg.cho_solve(cho, rhs * d[:, None]) * d[:, None]


@dataclass
class ShexpProbe:
    """A fitted probe: ``p`` ``((lmax_p+1)^2, 3)``, ``q`` ``((lmax_q+1)^2 − 1, 3)``."""

    p: np.ndarray
    q: np.ndarray
    stats: dict


class FitPlan:
    """The probe-independent part of a fit: samples, design matrix, factorisation.

    ``views``/``normals`` ``(T, 3)``: for each of ``config.normals`` Fibonacci
    normals, ``config.views`` views spread uniformly over its hemisphere; each
    pair at every roughness of ``config.roughness``. ``targets`` computes
    ``E0`` there: a :class:`QuadraturePlan` (``quadrature``, when given, is
    one built earlier for the same config and shape) or :class:`ShTargets`.
    """

    def __init__(self, config: FitConfig, shape: tuple[int, int], quadrature=None):
        self.config = config
        normals = fibonacci_sphere(config.normals)
        local = hemisphere_fibonacci(config.views)
        views = [local @ np.array([*tangent_frame(*n), n]) for n in normals]
        v1 = np.concatenate(views)
        n1 = np.repeat(normals, config.views, axis=0)
        r = config.roughness
        self.views = np.tile(v1, (r.size, 1))
        self.normals = np.tile(n1, (r.size, 1))
        self.roughness = np.repeat(r, v1.shape[0])
        self.A = design_rows(self.views, self.normals, self.roughness, config.lmax_p, config.lmax_q)
        if config.targets == "sh":
            self.targets = ShTargets(self.views, self.normals, self.roughness,
                                     config.targets_lmax, config.samples)  # fmt: skip
        else:
            self.targets = quadrature or QuadraturePlan.build(
                self.views, self.normals, self.roughness, config.samples, shape
            )
        self.unit_weights = np.ones(self.A.shape[0])
        self.unit_factor = _factor(self.A, self.unit_weights)

    def fit(self, pixels) -> ShexpProbe:
        """Fit ``p``, ``q`` to the map ``pixels`` (lat-long, the plan's shape)."""
        return self.fit_targets(self.targets.e0(pixels))

    def fit_targets(self, e0: np.ndarray) -> ShexpProbe:
        """Fit ``p``, ``q`` to given ``E0`` values at the plan's samples, ``(T, 3)``."""
        cfg = self.config
        floor = np.maximum(cfg.floor * e0.mean(axis=0), ABSOLUTE_FLOOR)
        floored = int((e0 < floor).sum())
        target = np.log(np.maximum(e0, floor))
        x = _solve(self.A, self.unit_weights, target, self.unit_factor)
        if cfg.weighting != "log":
            # relative: residual PQ/E0 − 1; linear: (PQ − E0)/mean(E0), the MSE's own proxy
            scale = np.ones_like(e0) if cfg.weighting == "relative" else np.exp(target - np.log(
                np.maximum(e0.mean(axis=0), ABSOLUTE_FLOOR)))  # fmt: skip
            for _ in range(GAUSS_NEWTON_STEPS):
                x = self._gauss_newton_step(x, target, scale)
        res = self.A @ x - target
        rel = np.expm1(res)
        n_p = n_coeffs(cfg.lmax_p)
        stats = {
            "log_rms": float(np.sqrt(np.mean(res**2))),
            "relative_rms": float(np.sqrt(np.mean(rel**2))),
            "floored_targets": floored,
            "targets": int(e0.shape[0]),
        }
        return ShexpProbe(x[:n_p], x[n_p:], stats)

    def _gauss_newton_step(self, x, target, scale):
        """One damped step on ``Σ_t s_t² (exp(A x − b)_t − 1)²`` per channel: the full
        Gauss–Newton step, halved until the sum decreases (at most 12 times)."""
        out = x.copy()
        for c in range(x.shape[1]):
            s, b = scale[:, c], target[:, c]
            e = np.exp(self.A @ x[:, c] - b)
            # J = diag(s e) A; residual s (e − 1); normal equations Jᵀ J δ = −Jᵀ s (e − 1)
            delta = _solve(self.A, (s * e) ** 2, ((1.0 - e) / e)[:, None])[:, 0]
            base = _scaled_cost(self.A, x[:, c], b, s)
            for k in range(STEP_HALVINGS + 1):
                trial = x[:, c] + 0.5**k * delta
                if _scaled_cost(self.A, trial, b, s) < base:
                    out[:, c] = trial
                    break
        return out


def _scaled_cost(A, x, b, s) -> float:
    """``Σ s² (exp(A x − b) − 1)²`` (overflow reads as +inf: the step is refused)."""
    with np.errstate(over="ignore"):
        return float(np.sum((s * np.expm1(A @ x - b)) ** 2))


@pjit
def _evaluate(views, normals, roughness, f0, p, q, lmax_p, lmax_q, qmm, a, b, table, out):
    for k in numba.prange(views.shape[0]):
        yp = np.empty((lmax_p + 1) ** 2)
        yq = np.empty((lmax_q + 1) ** 2)
        vx, vy, vz = views[k, 0], views[k, 1], views[k, 2]
        nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
        nv = nx * vx + ny * vy + nz * vz
        rx, ry, rz = 2 * nv * nx - vx, 2 * nv * ny - vy, 2 * nv * nz - vz
        hx, hy, hz = nx + rx, ny + ry, nz + rz
        hn = np.sqrt(hx * hx + hy * hy + hz * hz)
        sh_eval_into(rx, ry, rz, lmax_p, qmm, a, b, yp)
        sh_eval_into(hx / hn, hy / hn, hz / hn, lmax_q, qmm, a, b, yq)
        r = roughness[k]
        a0, a1 = table_lookup(table, nv, r)
        tail = a1 / a0 if a0 > 0.0 else 0.0
        for c in range(3):
            s = 0.0
            for l in range(lmax_p + 1):
                g = np.exp(-l * (l + 1) * r / 2.0)
                for i in range(l * l, (l + 1) * (l + 1)):
                    s += g * yp[i] * p[i, c]
            for l in range(1, lmax_q + 1):
                g = np.exp(-l * (l + 1) * r / 2.0)
                for i in range(l * l, (l + 1) * (l + 1)):
                    s += g * yq[i] * q[i - 1, c]
            e0 = np.exp(s)
            out[k, c] = f0[c] * e0 + (1.0 - f0[c]) * e0 * tail


def evaluate_shexp(p, q, table, views, normals, roughness, f0=(1.0, 1.0, 1.0)) -> np.ndarray:
    """Outgoing radiance ``(T, 3)`` of an SH-exp probe at world ``(v, n, r)``.

    ``f0``: Schlick reflectance per channel (1 = chrome: ``E0`` alone).
    Roughness must lie in the probe's fitted range; the caller checks it.
    """
    p = np.asarray(p, float)
    q = np.asarray(q, float)
    lmax_p = int(round(np.sqrt(p.shape[0]))) - 1
    lmax_q = int(round(np.sqrt(q.shape[0] + 1))) - 1
    v = np.ascontiguousarray(np.asarray(views, float).reshape(-1, 3))
    n = np.ascontiguousarray(np.asarray(normals, float).reshape(-1, 3))
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(roughness, float), (v.shape[0],)))
    out = np.empty((v.shape[0], 3))
    f0 = np.broadcast_to(np.asarray(f0, float), (3,)).copy()
    qmm, a, b = recurrence_tables(max(lmax_p, lmax_q))
    _evaluate(v, n, r, f0, p, q, lmax_p, lmax_q, qmm, a, b, np.asarray(table, float), out)
    return out
