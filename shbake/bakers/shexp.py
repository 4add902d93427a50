"""The SH-exponential glossy probe fit (Silvennoinen et al. 2025, §4).

``E0(v, n, r) ≈ P(ρ, r) Q(h_ρ, r)`` (eq. 9–11) with ``ρ = 2(n·v)n − v`` the
mirror direction, ``h_ρ = (n + ρ)/|n + ρ|``, and::

    P = exp(Σ_lm vMF_l(1/r) y_lm(ρ) p_lm),  Q = exp(Σ_lm vMF_l(1/r) y_lm(h_ρ) q_lm)
    vMF_l(κ) = exp(−l(l+1)/(2κ))                                    (eq. 12)

``p``: ``lmax_p`` (default 4, 25 coefficients); ``q``: ``lmax_q`` (default 2)
without its DC term (8), which ``p`` already holds (§4.1). ``r`` is the
paper's α, read as perceptual roughness (GGX width ``r²``, CONVENTIONS).
The fit (eq. 13–14) is linear least squares in log space over fixed
``(v, n, r)`` samples; everything but the right-hand side is built once
(:class:`FitPlan`). Shaded by :mod:`shbake.shading.shexp`.
"""

from dataclasses import asdict, dataclass

import numpy as np
import scipy.linalg

from shbake.bakers.shexp_sh_targets import ShTargets
from shbake.bakers.shexp_targets import QuadraturePlan
from shbake.brdf.sampling import tangent_frame
from shbake.conventions import (
    SH_TARGETS_LMAX_LIMIT,
    SHEXP_LMAX_LIMIT,
    check_roughness,
    n_coeffs,
)
from shbake.errors import ParameterError
from shbake.jit import jit
from shbake.sh.basis import real_sh
from shbake.sh.point_sets import fibonacci_sphere, hemisphere_fibonacci
from shbake.shading.shexp import mirror_and_half, vmf_factors

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
            (0 <= self.lmax_p <= SHEXP_LMAX_LIMIT, f"lmax_p must be in [0, {SHEXP_LMAX_LIMIT}]"),
            (1 <= self.lmax_q <= SHEXP_LMAX_LIMIT, f"lmax_q must be in [1, {SHEXP_LMAX_LIMIT}]"),
            (4 <= self.normals <= 4096, "normals must be in [4, 4096]"),
            (4 <= self.views <= 4096, "views must be in [4, 4096]"),
            (1 <= self.roughness_count <= 64, "roughness_count must be in [1, 64]"),
            (self.weighting in WEIGHTINGS, f"weighting must be one of {', '.join(WEIGHTINGS)}"),
            (np.isfinite(self.floor) and 0 < self.floor < 1, "floor must be in (0, 1)"),
            (self.targets in TARGETS, f"targets must be one of {', '.join(TARGETS)}"),
            (
                1 <= self.targets_lmax <= SH_TARGETS_LMAX_LIMIT,
                f"targets_lmax must be in [1, {SH_TARGETS_LMAX_LIMIT}]",
            ),
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
