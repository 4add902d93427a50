"""The SH-exponential glossy probe fit (Silvennoinen et al. 2025, §4), and shbake's v2.

``E0(v, n, α) ≈ P(ρ, α) Q(h_ρ, α)`` (eq. 9–11), ``ρ`` the mirror direction,
``h_ρ = (n + ρ)/|n + ρ|``, ``α`` the GGX width (SPEC §1)::

    log P Q = Σ_k h_k(α) [ Σ_lm vMF_l(1/α) y_lm(ρ) p_klm + Σ_lm vMF_l(1/α) y_lm(h_ρ) q_klm ]
    vMF_l(1/α) = exp(−l(l+1) α / 2)                                         (eq. 12)

with ``h_k`` the piecewise-linear hat functions of ``α`` on ``K`` knots spread
evenly over the fitted range (:func:`shbake.shading.shexp.hat_weights`;
``K = 1``: the paper's single set; ``K = 2``: coefficients linear in ``α``).
``p``: ``lmax_p`` (default 5, 36 coefficients per set; the paper's 4, 25); ``q``:
``lmax_q`` (default 2) without its DC term (8), which ``p`` already holds (§4.1).
Default fit (issue 33): 2 sets, ``lmax_p`` 5, 48 normals × 32 views × 8 α, two
polish steps, ``α`` weight 1 — 1056 bytes per probe; it beats the plain split-sum in 285
of the 288 shared-map cases (``docs/BENCHMARKS.md``; 283 without the ``α`` weight), where
2 sets at ``lmax_p`` 4, 64 normals and one step (792 bytes) won 279.

The fit is one weighted linear least-squares problem in log space over fixed
``(v, n, α)`` samples (eq. 13–14, all sets jointly), per channel::

    minimise Σ_t w_t (log P Q − log E0)_t²

``weights``: ``log`` — ``w = 1`` (eq. 13: the paper); ``shaded`` —
``w = E0²``, so that ``w · (log residual)² ≈ (P Q − E0)²``, the shaded
squared error the evaluation measures (``E0`` is the fit target, standing in
for ``P Q``); ``shaded-nv`` — ``w = E0² · 2 max(n·v, 0)``: the views of the
fit lattice are uniform over each hemisphere, and ``2 n·v`` is the density
ratio of the cosine-weighted distribution to it — the distribution of
``(v, n)`` pairs over the pixels of a rendered sphere (an orthographic view
sees normal ``n`` on ``n·v`` of its area). ``polish`` Gauss–Newton steps then
minimise the shaded error ``Σ_t 2 n·v (P Q − E0)²`` itself (weights
``shaded-nv`` only); each step is halved until the error decreases and a step
that does not decrease it is dropped ("where it helps").

``alpha_weight`` ``s`` multiplies every sample's weight (all three weightings, and the
polish) by ``(α_min/α)^s``: with ``s = 1`` a sample at ``α`` counts in proportion to
``1/α``. The split-sum a probe replaces is nearly exact at small ``α`` (its error grows
with the lobe), so SH-exp must be relatively more accurate there to beat it; the two
sets (linear in ``α``) cannot be as accurate at both ends, and ``1/α`` moves the balance
toward the narrow end (measured in ``docs/BENCHMARKS.md``: the dielectric at α 0.25 wins
22 of 24 shared-map cases instead of 20, every other (material, α) still ≥ 23).

``sets = 1, weights = log, alpha_count = 4`` over ``α ∈ [0.2, 1]`` with 64
normals × 64 uniform views is the paper's fit (§5.1). Everything but the
right-hand side is built once per configuration (:class:`FitPlan`). Shaded by
:mod:`shbake.shading.shexp`.
"""

import base64
from dataclasses import asdict, dataclass

import numpy as np

from shbake.bakers.shexp_targets import QuadraturePlan
from shbake.brdf.sampling import tangent_frame
from shbake.conventions import SH_TARGETS_LMAX_LIMIT, SHEXP_LMAX_LIMIT, n_coeffs
from shbake.errors import ParameterError
from shbake.reference.ggx import check_alpha
from shbake.sh.basis import real_sh
from shbake.sh.point_sets import fibonacci_sphere, hemisphere_fibonacci
from shbake.shading.shexp import hat_weights, mirror_and_half, vmf_factors

WEIGHTS = ("log", "shaded", "shaded-nv", "shaded-nv-f0")
DIELECTRIC_F0 = 0.04
SAMPLE_BYTES = 512
"""Working bytes per fit sample besides the quadrature entries: tiled views and normals,
``α``, weights, ``E0`` targets and their log, fitted values (tracemalloc:
``tests/system/faults/test_memory.py::TestProbeFitMemory``)."""
WEIGHTINGS = WEIGHTS  # the name cli/probe_fit.py imports until its grammar pass
FIT_TARGETS = ("quadrature", "sh")
SETS_LIMIT = 8
STEP_HALVINGS = 8
ABSOLUTE_FLOOR = 1e-30
FIT_ALPHA_MIN = 0.05
ALPHA_WEIGHT_LIMIT = 4.0
"""Narrowest GGX width a fit range may start at (SH-exp does not reach mirrors)."""


@dataclass(frozen=True)
class FitConfig:
    """Everything that shapes a fit; two probes fitted with equal configs are comparable.

    ``alpha_min``/``alpha_max``/``alpha_count``: the GGX widths of the fit
    samples, ``alpha_count`` evenly spaced over the range (the probe shades
    this range only). ``sets``: coefficient sets ``K`` (knots evenly spaced
    over the range). ``weights``, ``polish``: module docstring. ``floor``:
    ``E0`` below ``floor × mean(E0)`` (per channel, and below ``1e-30``) is
    raised to it before the log, so dark and black maps stay finite.
    ``targets``: how ``E0`` is computed at the fit samples — ``quadrature``
    (``samples`` filtered visible-normal samples each) or ``sh`` (SH lighting
    to ``targets_lmax`` × GGX tables). ``alpha_weight``: exponent ``s`` of the
    factor ``(alpha_min/α)^s`` on every sample's weight, in ``[0, 4]`` (module
    docstring; 0: every ``α`` weighed as its ``E0`` says).
    """

    lmax_p: int = 5
    lmax_q: int = 2
    normals: int = 48
    views: int = 32
    alpha_count: int = 8
    alpha_min: float = 0.2
    alpha_max: float = 1.0
    sets: int = 2
    weights: str = "shaded-nv"
    polish: int = 2
    samples: int = 1024
    floor: float = 1e-4
    targets: str = "quadrature"
    targets_lmax: int = 8
    alpha_weight: float = 1.0

    def __post_init__(self):
        checks = [
            (0 <= self.lmax_p <= SHEXP_LMAX_LIMIT, f"lmax_p must be in [0, {SHEXP_LMAX_LIMIT}]"),
            (1 <= self.lmax_q <= SHEXP_LMAX_LIMIT, f"lmax_q must be in [1, {SHEXP_LMAX_LIMIT}]"),
            (4 <= self.normals <= 4096, "normals must be in [4, 4096]"),
            (4 <= self.views <= 4096, "views must be in [4, 4096]"),
            (1 <= self.alpha_count <= 64, "alpha_count must be in [1, 64]"),
            (1 <= self.sets <= SETS_LIMIT, f"sets must be in [1, {SETS_LIMIT}]"),
            (
                self.sets == 1 or self.alpha_count >= 2 * self.sets - 1,
                "alpha_count must be at least 2·sets − 1 (every hat needs samples)",
            ),  # fmt: skip
            (self.weights in WEIGHTS, f"weights must be one of {', '.join(WEIGHTS)}"),
            (0 <= self.polish <= 8, "polish must be in [0, 8] Gauss–Newton steps"),
            (np.isfinite(self.floor) and 0 < self.floor < 1, "floor must be in (0, 1)"),
            (self.targets in FIT_TARGETS, f"targets must be one of {', '.join(FIT_TARGETS)}"),
            (
                1 <= self.targets_lmax <= SH_TARGETS_LMAX_LIMIT,
                f"targets_lmax must be in [1, {SH_TARGETS_LMAX_LIMIT}]",
            ),
            (
                np.isfinite(self.alpha_weight) and 0 <= self.alpha_weight <= ALPHA_WEIGHT_LIMIT,
                f"alpha_weight must be in [0, {ALPHA_WEIGHT_LIMIT:g}]",
            ),
        ]
        for ok, msg in checks:
            if not ok:
                raise ParameterError(msg)
        # -0.0 + 0.0 is 0.0: `--alpha-weight -0` is the same fit, so the same bytes
        object.__setattr__(self, "alpha_weight", float(self.alpha_weight) + 0.0)
        check_alpha([self.alpha_min, self.alpha_max], name="alpha range")
        if self.alpha_min < FIT_ALPHA_MIN:
            raise ParameterError(f"alpha range must start at {FIT_ALPHA_MIN:g} or above")
        if self.alpha_min > self.alpha_max or (
            self.alpha_count > 1 and self.alpha_min == self.alpha_max
        ):
            raise ParameterError("alpha range must be lo < hi (or one value with count 1)")
        if self.sets > 1 and self.alpha_min == self.alpha_max:
            raise ParameterError("several coefficient sets need an alpha range lo < hi")

    @classmethod
    def paper(cls, **changes) -> "FitConfig":
        """The paper's fit (§5.1): one set, ``lmax_p`` 4, log weights, 4 α samples over
        [0.2, 1], 64 normals × 64 views, no polish, no ``α`` weight."""
        paper = {"sets": 1, "weights": "log", "alpha_count": 4, "polish": 0, "views": 64,
                 "lmax_p": 4, "normals": 64, "alpha_weight": 0.0}  # fmt: skip
        return cls(**(paper | changes))

    @property
    def alphas(self) -> np.ndarray:
        """GGX widths of the fit samples."""
        return np.linspace(self.alpha_min, self.alpha_max, self.alpha_count)

    @property
    def knots(self) -> np.ndarray:
        """``α`` of the coefficient sets (one set: the range's low end, unused)."""
        return np.linspace(self.alpha_min, self.alpha_max, self.sets)

    @property
    def n_params(self) -> int:
        """Coefficients per channel and set."""
        return n_coeffs(self.lmax_p) + n_coeffs(self.lmax_q) - 1

    def as_dict(self) -> dict:
        return asdict(self)

    def memory(self, shape: tuple[int, int], maps: int = 1) -> int:
        """Estimated peak bytes of a :class:`FitPlan` for lat-long maps of ``shape`` and of
        fitting ``maps`` of them in one pass (:meth:`FitPlan.fit_many`).

        Terms (float64 unless said): per fit sample (``T = normals × views × alpha_count``)
        :data:`SAMPLE_BYTES` of geometry, weights and targets, and ``samples`` int32 +
        float32 quadrature entries twice (built, then compacted) — or the SH targets' GGX
        tables (one per ``α``) and rotated lighting; per normal–view pair ``Y`` and its
        upper-triangle products ``n (n+1)/2`` with the two factor copies numpy makes; the
        Gram matrices ``n² × alpha_count × 3`` three times and the normal matrices
        ``3 (K n)²`` twice; per map texel ``maps ×`` the filtered pyramid (4/3 of the
        texels × 3) twice. An upper bound of the measured peak
        (``tests/system/faults/test_memory.py::TestProbeFitMemory``).
        """
        pairs = self.normals * self.views
        t = pairs * self.alpha_count
        n = self.n_params
        total = t * SAMPLE_BYTES
        if self.targets == "quadrature":
            total += t * self.samples * 8 * 2
        else:  # one GGX table per α (brdf/tabulate.py) and the rotated lighting
            from shbake.bakers.shexp_sh_targets import TABLE_RESOLUTION
            from shbake.brdf.tabulate import table_bytes

            total += self.alpha_count * table_bytes(1, TABLE_RESOLUTION, self.targets_lmax)
            total += t * n_coeffs(self.targets_lmax) * 3 * 8 * 2
        total += pairs * (n + 3 * n * (n + 1) // 2) * 8  # Y; Y_i Y_j and its two factors
        total += 3 * n * n * self.alpha_count * 3 * 8 + 2 * 3 * (self.sets * n) ** 2 * 8
        total += maps * int(shape[0]) * int(shape[1]) * 4 // 3 * 3 * 8 * 2
        return int(total)


def design_rows(views, normals, alpha, lmax_p: int, lmax_q: int, knots) -> np.ndarray:
    """Rows of eq. 14 for ``K`` sets: ``h_k(α) [vMF ⊙ Y(ρ), (vMF ⊙ Y(h_ρ)) without DC]``
    for ``k = 0 … K−1`` side by side, ``(T, K · n_params)``."""
    rho, h = mirror_and_half(views, normals)
    yp = real_sh(rho, lmax_p) * vmf_factors(lmax_p, alpha)
    yq = real_sh(h, lmax_q) * vmf_factors(lmax_q, alpha)
    base = np.concatenate([yp, yq[:, 1:]], axis=1)
    hw = hat_weights(knots, alpha)
    return (hw[:, :, None] * base[:, None, :]).reshape(base.shape[0], -1)


class Design:
    """The rows of eq. 14 over a product lattice: every ``(v, n)`` pair at every fit ``α``.

    Row ``t = i·M + j`` (``α_i``, pair ``j``) is ``h(α_i) ⊗ (D(α_i) y_j)`` with ``y_j``
    the pair's unscaled basis row ``[Y(ρ), Y(h_ρ) without DC]`` (``(M, n)``, shared by
    every ``α``), ``D(α)`` the vMF factors and ``h(α)`` the hat weights
    (:func:`design_rows` writes the same rows out). Weighted normal matrices are
    then ``Σ_i (h_i h_iᵀ) ⊗ D_i (Yᵀ diag(w_i) Y) D_i``: ``N_α`` Gram matrices of
    ``n`` columns instead of one of ``K n`` columns over ``N_α M`` rows (BLAS).
    """

    def __init__(self, views, normals, alphas, lmax_p: int, lmax_q: int, knots):
        rho, h = mirror_and_half(views, normals)
        self.Y = np.concatenate([real_sh(rho, lmax_p), real_sh(h, lmax_q)[:, 1:]], axis=1)
        n_p = n_coeffs(lmax_p)
        self.D = np.concatenate(
            [vmf_factors(lmax_p, alphas), vmf_factors(lmax_q, alphas)[:, 1:]], axis=1
        )  # (N_α, n)
        self.H = hat_weights(knots, alphas)  # (N_α, K)
        self.n_p = n_p
        self.pairs = self.Y.shape[0]
        self.iu = np.triu_indices(self.Y.shape[1])
        # products Y_i Y_j of the upper triangle, one row per (i, j): row-major, the layout
        # BLAS multiplies fastest by the weights (the same sums as the pairs-major copy)
        yt = self.Y.T
        self.YY_t = yt[self.iu[0]] * yt[self.iu[1]]  # (n(n+1)/2, M)

    @property
    def n_params(self) -> int:
        return self.H.shape[1] * self.Y.shape[1]

    def _coeffs(self, x):
        """Per-``α`` blended, vMF-scaled coefficients ``(N_α, n)`` of one column ``x``."""
        sets = x.reshape(self.H.shape[1], -1)
        return (self.H @ sets) * self.D

    def apply(self, x):
        """``A x`` for one column ``x`` (``(K n,)``), as ``(N_α · M,)``."""
        return (self.Y @ self._coeffs(x).T).T.reshape(-1)

    def normal_matrices(self, w):
        """``Aᵀ diag(w_c) A`` for each column ``w_c`` of ``w`` ``(N_α · M, C)``; ``(C, K n, K n)``.

        One BLAS product ``(Y_i Y_j)ᵀ W`` over the pairs' upper-triangle products
        (built once) gives every ``Yᵀ diag(w) Y`` at every ``α`` and channel."""
        K, n, n_a = self.H.shape[1], self.Y.shape[1], self.H.shape[0]
        c = w.shape[1]
        wm = w.reshape(n_a, self.pairs, c).transpose(1, 0, 2).reshape(self.pairs, n_a * c)
        tri = (self.YY_t @ wm).reshape(-1, n_a, c)  # (n(n+1)/2, N_α, C)
        g = np.empty((n, n, n_a, c))
        g[self.iu] = tri
        g[self.iu[1], self.iu[0]] = tri
        g *= self.D.T[:, None, :, None] * self.D.T[None, :, :, None]  # D_i G_i D_i
        hh = self.H[:, :, None] * self.H[:, None, :]  # (N_α, K, K)
        out = np.einsum("akl,ijac->ckilj", hh, g, optimize=True)
        return out.reshape(c, K * n, K * n)

    def rhs(self, wb):
        """``Aᵀ (w ⊙ b)`` for weighted columns ``wb`` ``(N_α · M, C)``; ``(K n, C)``."""
        n_a, c = self.H.shape[0], wb.shape[1]
        wm = wb.reshape(n_a, self.pairs, c).transpose(1, 0, 2).reshape(self.pairs, n_a * c)
        yb = (self.Y.T @ wm).reshape(-1, n_a, c) * self.D.T[:, :, None]  # (n, N_α, C)
        return np.einsum("iac,ak->kic", yb, self.H).reshape(-1, c)

    def solve(self, w, b):
        """``argmin Σ_t w_tc (A x − b)_tc²`` per column ``c`` of ``b`` ``(T, C)`` with weights
        ``w`` ``(T, C)``: Cholesky of the column-scaled normal equations (numpy only: no
        scipy import per worker); ``(K n, C)``."""
        mats = self.normal_matrices(w)
        rhs = self.rhs(w * b)
        x = np.empty_like(rhs)
        for c, m in enumerate(mats):
            d = 1.0 / np.sqrt(np.maximum(np.diag(m), 1e-300))
            m = m * d[:, None] * d[None, :]
            m[np.diag_indices_from(m)] += 1e-12
            chol = np.linalg.cholesky(m)
            x[:, c] = np.linalg.solve(chol.T, np.linalg.solve(chol, rhs[:, c] * d)) * d
        return x


def _material_balance(nv, alpha, dfg=None):
    """Per-sample factor giving chrome and dielectric (``F0 = 0.04``) equal say in the fit.

    A dielectric's shaded error is about the chrome one times ``m = (F0 + (1 − F0)
    A1/A0)²`` (exactly so with eq. 15's tail, ``E1 = E0 A1/A0``; the shader's tail reads
    ``E0`` at the mirror direction instead), which grows toward grazing views;
    ``1/S_c + m/S_d`` (``S`` the means of ``2 n·v`` and ``2 n·v m`` at each ``α``) weighs
    both materials' relative errors equally.
    """
    from shbake.bakers.dfg import dfg_table
    from shbake.shading.dfg import dfg_lookup

    table = dfg_table() if dfg is None else dfg
    a = dfg_lookup(table, nv, alpha)
    m = (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * a[:, 1] / np.maximum(a[:, 0], 1e-12)) ** 2
    out = np.empty_like(m)
    for x in np.unique(alpha):
        k = alpha == x
        s_c, s_d = np.mean(2.0 * nv[k]), np.mean(2.0 * nv[k] * m[k])
        out[k] = 0.5 * (1.0 + m[k] * s_c / s_d)
    return out


@dataclass
class ShexpProbe:
    """A fitted probe: ``p`` ``(K, (lmax_p+1)^2, 3)``, ``q`` ``(K, (lmax_q+1)^2 − 1, 3)``,
    the sets' ``knots`` ``(K,)``."""

    p: np.ndarray
    q: np.ndarray
    knots: np.ndarray
    stats: dict

    def to_record(self) -> dict:
        """The probe as JSON values, every float64 kept exactly (little-endian bytes in
        base64): what a scene's plan keeps of its fit for the bake (:meth:`from_record`)."""
        return {k: base64.b64encode(np.asarray(getattr(self, k), "<f8").tobytes()).decode()
                for k in ("p", "q", "knots")} | {"stats": self.stats}  # fmt: skip

    @classmethod
    def from_record(cls, record, config: "FitConfig") -> "ShexpProbe | None":
        """The probe :meth:`to_record` wrote for a fit at ``config``; ``None`` when
        ``record`` is not one (it comes from a lock or cache file: untrusted) — wrong
        shapes, non-finite coefficients, stats that are not :meth:`FitPlan.fit_targets`'."""
        if not isinstance(record, dict) or record.keys() != {"p", "q", "knots", "stats"}:
            return None
        K = config.sets
        shapes = {"p": (K, n_coeffs(config.lmax_p), 3), "q": (K, n_coeffs(config.lmax_q) - 1, 3),
                  "knots": (K,)}  # fmt: skip
        arrays = {}
        for k, shape in shapes.items():
            try:
                raw = base64.b64decode(record[k], validate=True)
            except (TypeError, ValueError):
                return None
            if len(raw) != 8 * int(np.prod(shape)):
                return None
            arrays[k] = np.frombuffer(raw, "<f8").astype(np.float64).reshape(shape)
            if not np.all(np.isfinite(arrays[k])):
                return None
        stats = record["stats"]
        if not (isinstance(stats, dict) and stats.keys() == set(FIT_STATS)
                and all(isinstance(stats[k], kind) and not isinstance(stats[k], bool)
                        for k, kind in FIT_STATS.items())):  # fmt: skip
            return None
        by_alpha = stats["shaded_relative_rms_by_alpha"]
        if len(by_alpha) != config.alpha_count or not all(type(x) is float for x in by_alpha):
            return None
        return cls(arrays["p"], arrays["q"], arrays["knots"], dict(stats))


FIT_STATS = {"log_rms": float, "shaded_relative_rms": float, "shaded_relative_rms_by_alpha": list,
             "floored_targets": int, "targets": int, "polish_steps": int}  # fmt: skip
"""The keys and types of a fit's ``stats`` (:meth:`FitPlan.fit_targets`)."""


class FitPlan:
    """The probe-independent part of a fit: samples, design matrix, view weights.

    ``views``/``normals`` ``(T, 3)``: for each of ``config.normals`` Fibonacci
    normals, ``config.views`` views spread uniformly over its hemisphere; each
    pair at every ``α`` of ``config.alphas``. ``targets`` computes ``E0``
    there: a :class:`QuadraturePlan` (``quadrature``, when given, is one built
    earlier for the same config and shape) or :class:`ShTargets`.
    """

    def __init__(self, config: FitConfig, shape: tuple[int, int], quadrature=None, dfg=None):
        self.config = config
        normals = fibonacci_sphere(config.normals)
        local = hemisphere_fibonacci(config.views)
        views = [local @ np.array([*tangent_frame(*n), n]) for n in normals]
        v1 = np.concatenate(views)
        n1 = np.repeat(normals, config.views, axis=0)
        a = config.alphas
        self.views = np.tile(v1, (a.size, 1))
        self.normals = np.tile(n1, (a.size, 1))
        self.alpha = np.repeat(a, v1.shape[0])
        self.knots = config.knots
        self.design = Design(v1, n1, a, config.lmax_p, config.lmax_q, self.knots)
        nv = np.maximum(np.einsum("ij,ij->i", self.views, self.normals), 0.0)
        self.view_weight = 2.0 * nv
        self.alpha_factor = (config.alpha_min / self.alpha) ** config.alpha_weight
        self.sample_weight = self.view_weight * self.alpha_factor
        if config.weights == "shaded-nv-f0":
            self.sample_weight = self.sample_weight * _material_balance(nv, self.alpha, dfg)
        if config.targets == "sh":
            from shbake.bakers.shexp_sh_targets import ShTargets  # scipy.fft: only when asked

            self.targets = ShTargets(self.views, self.normals, self.alpha,
                                     config.targets_lmax, config.samples)  # fmt: skip
        else:
            self.targets = quadrature or QuadraturePlan.build(
                self.views, self.normals, self.alpha, config.samples, shape
            )

    def fit(self, pixels) -> ShexpProbe:
        """Fit the sets to the map ``pixels`` (lat-long, the plan's shape)."""
        return self.fit_targets(self.targets.e0(pixels))

    def fit_many(self, maps) -> list[ShexpProbe]:
        """:meth:`fit` of several maps, their targets gathered in one pass (quadrature
        targets); each probe equals :meth:`fit` of its map bit for bit."""
        if not hasattr(self.targets, "e0_many"):
            return [self.fit(m) for m in maps]
        return [self.fit_targets(e0) for e0 in self.targets.e0_many(maps)]

    def fit_targets(self, e0: np.ndarray) -> ShexpProbe:
        """Fit the sets to given ``E0`` values at the plan's samples, ``(T, 3)``."""
        cfg = self.config
        floor = np.maximum(cfg.floor * e0.mean(axis=0), ABSOLUTE_FLOOR)
        floored = int((e0 < floor).sum())
        target_lin = np.maximum(e0, floor)
        target = np.log(target_lin)
        if cfg.weights == "log":
            w = self.alpha_factor
        else:
            # scale-free: E0 relative to its channel mean, so weights stay O(1)
            rel = target_lin / target_lin.mean(axis=0)
            per_sample = self.sample_weight if cfg.weights != "shaded" else self.alpha_factor
            w = rel**2 * per_sample[:, None]
        x = self.design.solve(np.broadcast_to(w.reshape(w.shape[0], -1), target.shape), target)
        polished = 0
        if cfg.weights.startswith("shaded-nv"):
            for _ in range(cfg.polish):
                x, took = self._polish_step(x, target_lin)
                polished += took
        n_p = n_coeffs(cfg.lmax_p)
        K, n = cfg.sets, cfg.n_params
        sets = x.reshape(K, n, 3)
        stats = self._stats(x, target, target_lin) | {
            "floored_targets": floored, "targets": int(e0.shape[0]), "polish_steps": polished,
        }  # fmt: skip
        return ShexpProbe(sets[:, :n_p], sets[:, n_p:], self.knots.copy(), stats)

    def _shaded_cost(self, x, target_lin, c):
        with np.errstate(over="ignore"):
            pq = np.exp(self.design.apply(x))
        return float(np.sum(self.sample_weight * (pq - target_lin[:, c]) ** 2)), pq

    def _polish_step(self, x, target_lin):
        """One Gauss–Newton step per channel on ``Σ 2n·v (P Q − E0)²`` (module docstring),
        the three channels' normal equations built in one pass; returns the new
        coefficients and how many channels took their step."""
        out = x.copy()
        took = 0
        costs = [self._shaded_cost(x[:, c], target_lin, c) for c in range(x.shape[1])]
        pq = np.stack([p for _, p in costs], axis=1)
        # J = diag(PQ) A; residual PQ − E0; (Jᵀ W J) δ = −Jᵀ W (PQ − E0)
        w = self.sample_weight[:, None] * (pq / target_lin.mean(axis=0)) ** 2
        delta = self.design.solve(w, (target_lin - pq) / pq)
        for c, (base, _) in enumerate(costs):
            for k in range(STEP_HALVINGS + 1):
                trial = x[:, c] + 0.5**k * delta[:, c]
                cost, _ = self._shaded_cost(trial, target_lin, c)
                if cost < base:
                    out[:, c] = trial
                    took += 1
                    break
        return out, took

    def _stats(self, x, target, target_lin) -> dict:
        """Log residual, and the shaded relative error ``√(Σ 2n·v (PQ − E0)² / Σ 2n·v E0²)``
        overall and per fit ``α``."""
        fit = np.stack([self.design.apply(x[:, c]) for c in range(3)], axis=1)
        res = fit - target
        rel = np.minimum(np.expm1(np.minimum(fit - target, 30.0)), 1e12)  # finite for any fit
        err = (target_lin * rel) ** 2
        w = self.view_weight[:, None]
        n_a = self.config.alpha_count
        num = (w * err).reshape(n_a, -1).sum(axis=1)
        den = (w * target_lin**2).reshape(n_a, -1).sum(axis=1)
        by_alpha = [float(x) for x in np.sqrt(num / den)]
        return {
            "log_rms": float(np.sqrt(np.mean(res**2))),
            "shaded_relative_rms": float(np.sqrt(np.sum(w * err) / np.sum(w * target_lin**2))),
            "shaded_relative_rms_by_alpha": by_alpha,
        }
