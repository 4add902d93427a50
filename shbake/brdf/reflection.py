"""A BRDF reparameterised by the reflection vector, and its real SH coefficients ``ρ̂_lpq``
(Ramamoorthi & Hanrahan 2002, "RH02": §3.1, eq. 13, §5.1, appendices B–D).

Real-basis forms (derivation in ``docs/CONVENTIONS.md`` § SHRM). The BRDF is
reparameterised by the reflection vector ``R`` (§3.1): in a frame with ``R``
at +Z, the light ``ω_i`` and the view ``ω_o`` have polar angles ``θ_i``,
``θ_o`` about ``R`` and relative azimuth ``φ = φ_o − φ_i``; the normal is
``n = (R + V)/|R + V|`` and ``ρ̂ = f(ω_i, ω_o) max(0, n·ω_i)``. Isotropy
makes ``ρ̂`` a function of ``(θ_i, θ_o, φ)``, even in ``φ``, so in shbake's real
basis (SPEC §2) its expansion pairs equal indices::

    ρ̂(ω_i, ω_o) = Σ_{l,p} Σ_{|q| ≤ min(l,p)} ρ̂_{l p |q|} y_lq(ω_i) y_pq(ω_o)          (eq. 13, real)
    ρ̂_lpq = 2π ∫∫∫ ρ̂(θ_i, θ_o, φ) P̄_l^q(cos θ_i) P̄_p^q(cos θ_o) cos(qφ) sinθ_i sinθ_o dφ dθ_o dθ_i

with ``P̄_l^q`` the normalised Legendre functions of :mod:`shbake.sh.basis`
(``y_lq = √2 P̄_l^q cos qφ``). These are the paper's numbers: its ``f_lq f_pq``
carries the Condon–Shortley sign twice. They are computed by the separable
three-step quadrature of appendix C (φ, then ``θ_o``, then ``θ_i``).

Reparameterisations (:data:`REPARAMETERISATIONS`):

- ``surface``: any isotropic model of :mod:`shbake.brdf` (``phong``,
  ``blinn-phong``, ``ggx`` with equal widths, ``ward`` with equal widths,
  ``ashikhmin-shirley`` with equal exponents, ``lambert``, ``merl``,
  ``microfacet`` (eq. 11), ``lafortune``);
- ``lobe``: ``phong-lobe``, the paper's radially symmetric Phong of §6.3,
  ``ρ̂ = (s+1)/(2π) max(0, R·ω_i)^s`` over the whole sphere (no horizon):
  ``P = 0``, a 2D reflection map;
- ``tangent``: ``kajiya-kay`` reparameterised by the fibre tangent ``T``
  (§3.1, §7.1): ``cos θ_i = T·ω_i``, ``cos θ_o = T·V``, no azimuth, so only
  ``q = 0`` and ``P + 1`` terms ``B_p0(T)``; shading ``Σ_p B_p0(T) y_p0(T·V)``.

Orders (§5.1, appendix B–D): the BRDF energy ``Σ U_q ρ̂_lpq²`` (``U_0 = 1``,
``U_q = 2``: the ``±q`` pair) against the total ``∫∫ ρ̂² dω_i dω_o``; the
smallest ``P`` capturing ``1 − ε`` with ``F`` at its limit, then the smallest
``F`` at that ``P`` (appendix C). The SHRM itself is baked by
:mod:`shbake.bakers.shrm`.
"""

from dataclasses import dataclass, field

import numpy as np

from shbake.brdf import kajiya_kay
from shbake.brdf.dispatch import brdf_eval
from shbake.brdf.model import NO_DATA, make_brdf
from shbake.brdf.sampling import tangent_frame
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.basis import real_sh_numba
from shbake.sh.point_sets import gauss_legendre

F_LIMIT = 64
"""Largest ``F`` (light × BRDF band limit); the rotation is verified to ``l = 64``."""
P_LIMIT = 16
"""Largest ``P`` (view band limit)."""

REPARAMETERISATIONS = ("surface", "lobe", "tangent")
"""How a BRDF is reparameterised by the reflection vector (module docstring); the kernels'
``kind`` id is the index here."""
LOBE_MODELS = ("phong-lobe",)
TANGENT_MODELS = ("kajiya-kay",)

_PAIRED = {"ggx": ("alpha_x", "alpha_y"), "ward": ("alpha_x", "alpha_y"),
           "ashikhmin-shirley": ("nu", "nv")}  # fmt: skip


@dataclass
class ReflectionBRDF:
    """A BRDF as the SHRM sees it: a kind, a kernel model id and packed parameters.

    Attributes
    ----------
    name : str
        Model name (``phong-lobe``, ``kajiya-kay`` or a :mod:`shbake.brdf` model).
    kind : str
        ``surface``, ``lobe`` or ``tangent`` (module docstring).
    model_id : int
        Kernel id of the :mod:`shbake.brdf` model (``-1`` for ``phong-lobe``).
    prm : ndarray
        Packed parameters the kernels read.
    values : dict
        Resolved parameter values (JSON-ready through :meth:`describe`).
    data : ndarray
        Measured data (MERL) or a placeholder.
    source : str
        Path of measured data, else ``""``.
    source_sha256 : str
        Hex SHA-256 of the bytes ``data`` was decoded from, else ``""``.
    """

    name: str
    kind: str
    model_id: int
    prm: np.ndarray
    values: dict
    data: np.ndarray = field(default_factory=lambda: NO_DATA)
    source: str = ""
    source_sha256: str = ""

    @property
    def kind_id(self) -> int:
        return REPARAMETERISATIONS.index(self.kind)

    @property
    def radially_symmetric(self) -> bool:
        """True when ``ρ̂`` depends on ``θ_i`` alone (``P = 0``)."""
        return self.kind == "lobe"

    def describe(self) -> dict:
        vals = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.values.items()}
        return {"model": self.name, "kind": self.kind, "parameters": vals, "source": self.source}


def make_reflection_brdf(name: str, params: dict | None = None, merl_path: str | None = None):
    """Validate a model name and parameters for the SHRM; return a :class:`ReflectionBRDF`.

    ``phong-lobe`` takes ``s`` (exponent, 0 … 1e4, default 32). Anisotropic
    settings of ``ggx``/``ward``/``ashikhmin-shirley`` are refused (the SHRM
    needs an isotropic BRDF); ``alpha``/``n`` aliases set both widths.
    """
    params = dict(params or {})
    if name in LOBE_MODELS:
        if merl_path is not None:
            raise ParameterError("a MERL file is only used by the merl model")
        unknown = set(params) - {"s"}
        if unknown:
            raise ParameterError(f"model 'phong-lobe' has no parameter {sorted(unknown)[0]!r} "
                                 "(allowed: s)")  # fmt: skip
        s = params.get("s", 32.0)
        try:
            s = float(s)
        except (TypeError, ValueError):
            raise ParameterError(f"phong-lobe: s={s!r} is not a number") from None
        if not np.isfinite(s) or not 0.0 <= s <= 1e4:
            raise ParameterError(f"phong-lobe: s={s:g} is outside [0, 10000] (Phong exponent)")
        return ReflectionBRDF(name, "lobe", -1, np.array([s]), {"s": s})
    brdf = make_brdf(name, merl_path, **params)
    if name in _PAIRED:
        a, b = _PAIRED[name]
        if brdf.values[a] != brdf.values[b]:
            raise ParameterError(
                f"{name}: the SHRM needs an isotropic BRDF, got {a}={brdf.values[a]:g} ≠ "
                f"{b}={brdf.values[b]:g} (set both, e.g. -p {a[:-2]}=…)"
            )
    kind = "tangent" if name in TANGENT_MODELS else "surface"
    return ReflectionBRDF(name, kind, brdf.spec.model_id, brdf.packed, brdf.values,
                          brdf.data, brdf.source, brdf.source_sha256)  # fmt: skip


# ---------------------------------------------------------------------------------------------
# Step 1 of appendix C: ρ̂ on the (θ_i, θ_o, φ) grid


@jit
def rho_hat(kind, model, prm, data, ci, si, co, so, cphi, sphi, f, out):
    """``out[0:3] = ρ̂(θ_i, θ_o, φ)`` of the reparameterised BRDF (check-free kernel).

    ``(ci, si)``, ``(co, so)``: cos/sin of the polar angles about ``R`` (or the
    tangent for ``kind = 2``), ``(cphi, sphi)`` of the relative azimuth; ``f``
    is a scratch ``(3,)`` array. Light ``(si, 0, ci)``, view
    ``(so cphi, so sphi, co)`` in the frame with ``R`` at +Z.
    """
    if kind == 1:  # phong-lobe
        v = 0.0
        if ci > 0.0:
            s = prm[0]
            v = (s + 1.0) / (2.0 * np.pi) * (np.exp(s * np.log(ci)) if s > 0.0 else 1.0)
        out[0] = out[1] = out[2] = v
        return
    if kind == 2:  # kajiya-kay about the tangent
        kajiya_kay.evaluate(prm, ci, si, 0.0, co, so, 0.0, out)
        return
    vx, vy, vz = so * cphi, so * sphi, co
    nx, ny, nz = vx, vy, 1.0 + vz
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    out[0] = out[1] = out[2] = 0.0
    if norm < 1e-12:
        return
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    lz = si * nx + ci * nz
    v_z = vx * nx + vy * ny + vz * nz
    if lz <= 0.0 or v_z <= 0.0:
        return
    (tx, ty, tz), (bx, by, bz) = tangent_frame(nx, ny, nz)
    lx = si * tx + ci * tz
    ly = si * bx + ci * bz
    v_x = vx * tx + vy * ty + vz * tz
    v_y = vx * bx + vy * by + vz * bz
    brdf_eval(model, prm, data, lx, ly, lz, v_x, v_y, v_z, f)
    for c in range(3):
        out[c] = f[c] * lz


@jit
def _rho_grid_rows(kind, model, prm, data, xi, xo, phi, out, b0, b1):
    for i in range(b0, b1):
        f = np.empty(3)
        v = np.empty(3)
        ci = xi[i]
        si = np.sqrt(max(0.0, 1.0 - ci * ci))
        for o in range(xo.shape[0]):
            co = xo[o]
            so = np.sqrt(max(0.0, 1.0 - co * co))
            for k in range(phi.shape[0]):
                rho_hat(
                    kind, model, prm, data, ci, si, co, so, np.cos(phi[k]), np.sin(phi[k]), f, v
                )
                out[i, o, k, 0] = v[0]
                out[i, o, k, 1] = v[1]
                out[i, o, k, 2] = v[2]


def rho_grid(kind, model, prm, data, xi, xo, phi, out) -> None:
    """``out[i, o, k] = ρ̂(cos θ_i = xi[i], cos θ_o = xo[o], φ = phi[k])`` (RGB,
    :func:`rho_hat`) for a BRDF's numba ids and parameters; rows ``i`` in parallel
    (:func:`~shbake.jit.run_blocks`)."""
    run_blocks(_rho_grid_rows, xi.shape[0], out.size * 40.0, kind, model, prm, data, xi, xo,
               phi, out)  # fmt: skip


def legendre_table(x, lmax: int, qmax: int) -> np.ndarray:
    """``P̄_l^q(x)`` for ``l ≤ lmax``, ``q ≤ min(l, qmax)``: array ``(lmax+1, qmax+1, len(x))``.

    Read off :func:`shbake.sh.basis.real_sh` at ``(sqrt(1−x²), 0, x)``
    (``y_l0 = P̄_l^0``, ``y_lq = √2 P̄_l^q`` there); zero where ``q > l``.
    """
    x = np.asarray(x, dtype=float)
    d = np.stack([np.sqrt(np.maximum(0.0, 1.0 - x * x)), np.zeros_like(x), x], axis=-1)
    y = real_sh_numba(d, lmax)
    out = np.zeros((lmax + 1, qmax + 1, x.size))
    for l in range(lmax + 1):
        for q in range(min(l, qmax) + 1):
            v = y[:, l * (l + 1) + q]
            out[l, q] = v if q == 0 else v / np.sqrt(2.0)
    return out


@dataclass
class Quadrature:
    """Nodes and weights of the three-step BRDF quadrature (appendix C).

    ``xi``, ``wi``: Gauss–Legendre in ``cos θ_i`` over [−1, 1]; ``xo``, ``wo``
    the same in ``cos θ_o``; ``phi``, ``wphi``: trapezoid over ``φ ∈ [0, π]``
    with weights summing to ``2π`` (``ρ̂`` is even in ``φ``).
    """

    xi: np.ndarray
    wi: np.ndarray
    xo: np.ndarray
    wo: np.ndarray
    phi: np.ndarray
    wphi: np.ndarray

    @property
    def shape(self):
        return (self.xi.size, self.xo.size, self.phi.size)


def default_quadrature(kind: str, n_theta_i: int = 320, n_theta_o: int = 64, n_phi: int = 64):
    """The quadrature used by default: ``n_theta_i`` nodes about ``R``, etc.

    Resolves lobes down to ``σ ≈ 0.05`` rad / Phong exponents ≈ 2000; radially
    symmetric lobes take one ``θ_o`` and one ``φ`` node, tangent lobes no ``φ``.
    """
    xi, wi = gauss_legendre(n_theta_i)
    if kind == "lobe":
        xo, wo = np.array([0.0]), np.array([2.0])
    else:
        xo, wo = gauss_legendre(n_theta_i if kind == "tangent" else n_theta_o)
    if kind == "surface":
        phi = np.linspace(0.0, np.pi, n_phi + 1)
        wphi = np.full(n_phi + 1, 2.0 * np.pi / n_phi)
        wphi[[0, -1]] *= 0.5
    else:
        phi, wphi = np.array([0.0]), np.array([2.0 * np.pi])
    return Quadrature(xi, wi, xo, wo, phi, wphi)


@dataclass
class BRDFCoefficients:
    """``ρ̂_lpq`` of a reparameterised BRDF and its total energy.

    Attributes
    ----------
    rho : (F+1, P+1, P+1, 3)
        ``ρ̂[l, p, q, c]`` for ``q ≥ 0`` (zero where ``q > min(l, p)``).
    total : (3,)
        ``∫∫ ρ̂² dω_i dω_o`` per channel (the same quadrature).
    """

    rho: np.ndarray
    total: np.ndarray

    @property
    def F(self) -> int:
        return self.rho.shape[0] - 1

    @property
    def P(self) -> int:
        return self.rho.shape[1] - 1

    def band_energy(self) -> np.ndarray:
        """``e[l, p, c] = Σ_q U_q ρ̂_lpq²`` (``U_0 = 1``, ``U_q = 2``)."""
        u = np.full(self.rho.shape[2], 2.0)
        u[0] = 1.0
        return np.einsum("lpqc,q->lpc", self.rho**2, u)

    def captured(self) -> np.ndarray:
        """Energy fraction kept by ``l ≤ F``, ``p ≤ P``: ``(F+1, P+1)``, worst channel."""
        cum = np.cumsum(np.cumsum(self.band_energy(), axis=0), axis=1)
        live = self.total > 0.0
        if not np.any(live):
            return np.ones(cum.shape[:2])
        return np.min(cum[:, :, live] / self.total[live], axis=2)

    def truncated(self, F: int, P: int) -> "BRDFCoefficients":
        return BRDFCoefficients(np.ascontiguousarray(self.rho[: F + 1, : P + 1, : P + 1]),
                                self.total)  # fmt: skip


def brdf_coefficients(rb: ReflectionBRDF, F: int, P: int, quad: Quadrature | None = None):
    """``ρ̂_lpq`` for ``l ≤ F``, ``p ≤ P`` by the three-step algorithm of appendix C.

    Default quadrature: ``clip(4F+64, 128, 320)`` nodes in ``θ_i``,
    ``clip(4P+24, 32, 64)`` in ``θ_o``, ``clip(4P+16, 24, 64)`` in ``φ``
    (measured against 640 × 128 × 128 nodes: ≤ 1e-4 of the largest
    coefficient for the microfacet σ = 0.1 and Lafortune skin, ≤ 2e-3 for GGX
    α = 0.0625).
    Step 1 ``ρ̂_q(θ_i, θ_o) = 2π ∫ ρ̂ cos qφ dφ``; step 2
    ``ρ̂_pq(θ_i) = ∫ ρ̂_q P̄_p^q(cos θ_o) d cos θ_o``; step 3
    ``ρ̂_lpq = ∫ ρ̂_pq P̄_l^q(cos θ_i) d cos θ_i``. Cost ``O(P S T²)``.
    Returns :class:`BRDFCoefficients`.
    """
    if rb.kind != "surface":
        P_q = 0
    else:
        P_q = P
    if rb.kind == "lobe":
        P = 0
    if quad is None:
        quad = default_quadrature(
            rb.kind, int(np.clip(4 * F + 64, 128, 320)), int(np.clip(4 * P + 24, 32, 64)),
            int(np.clip(4 * P + 16, 24, 64)),
        )  # fmt: skip
    grid = np.zeros(quad.shape + (3,))
    rho_grid(rb.kind_id, rb.model_id, np.ascontiguousarray(rb.prm, dtype=float), rb.data,
              quad.xi, quad.xo, quad.phi, grid)  # fmt: skip
    q = np.arange(P_q + 1)
    cosq = np.cos(q[:, None] * quad.phi[None, :]) * quad.wphi[None, :]
    step1 = 2.0 * np.pi * np.tensordot(grid, cosq, axes=([2], [1])).transpose(3, 0, 1, 2)
    # the φ weights sum to 2π; the full-circle azimuth of ω_i gives another 2π
    sq = np.tensordot(grid**2, quad.wphi, axes=([2], [0]))  # (i, o, c)
    total = 2.0 * np.pi * np.tensordot(quad.wi, np.tensordot(sq, quad.wo, axes=([1], [0])), 1)
    po = legendre_table(quad.xo, P, P_q) * quad.wo  # (p, q, o)
    step2 = np.einsum("qioc,pqo->pqic", step1, po)
    pi = legendre_table(quad.xi, F, P_q) * quad.wi  # (l, q, i)
    rho = np.einsum("pqic,lqi->lpqc", step2, pi)
    full = np.zeros((F + 1, P + 1, P + 1, 3))
    full[:, :, : P_q + 1] = rho
    for l in range(F + 1):
        for p in range(P + 1):
            full[l, p, min(l, p) + 1 :] = 0.0
    return BRDFCoefficients(full, total)


# ---------------------------------------------------------------------------------------------
# Order selection (§5.1, appendices B–D)


@dataclass
class Orders:
    """``F``, ``P`` and the BRDF energy they leave out (``eps_brdf``, worst channel)."""

    F: int
    P: int
    eps_brdf: float
    eps_target: float
    reached: bool


def check_eps(eps) -> float:
    try:
        e = float(eps)
    except (TypeError, ValueError):
        raise ParameterError(f"eps must be a number in (0, 1), got {eps!r}") from None
    if not (np.isfinite(e) and 0.0 < e < 1.0):
        raise ParameterError(f"eps must lie strictly between 0 and 1, got {eps!r}")
    return e


def check_F(F) -> int | None:
    if F is None:
        return None
    if isinstance(F, bool) or not isinstance(F, int | np.integer) or not 0 <= F <= F_LIMIT:
        raise ParameterError(f"F must be an integer in [0, {F_LIMIT}], got {F!r}")
    return int(F)


def check_P(P) -> int | None:
    if P is None:
        return None
    if isinstance(P, bool) or not isinstance(P, int | np.integer) or not 0 <= P <= P_LIMIT:
        raise ParameterError(f"P must be an integer in [0, {P_LIMIT}], got {P!r}")
    return int(P)


def select_orders(coeffs: BRDFCoefficients, eps: float, F=None, P=None) -> Orders:
    """The smallest ``F``, ``P`` capturing ``1 − ε`` of the BRDF energy (appendix C's rule).

    With neither given: ``P`` is the smallest reaching the target at the
    largest ``F`` computed, then ``F`` the smallest at that ``P``. A given
    ``F`` or ``P`` is kept and the other chosen. When the target cannot be
    reached within the limits the largest orders are used and ``reached``
    is False.
    """
    eps = check_eps(eps)
    cap = coeffs.captured()
    target = 1.0 - eps
    Fmax, Pmax = cap.shape[0] - 1, cap.shape[1] - 1

    def first(arr):
        idx = np.nonzero(arr >= target)[0]
        return (int(idx[0]), True) if idx.size else (len(arr) - 1, False)

    if F is None and P is None:
        P, ok_p = first(cap[Fmax, :])
        F, ok_f = first(cap[:, P])
        ok = ok_p and ok_f
    elif F is None:
        F, ok = first(cap[:, min(P, Pmax)])
    elif P is None:
        P, ok = first(cap[min(F, Fmax), :])
    else:
        ok = cap[min(F, Fmax), min(P, Pmax)] >= target
    left_out = 1.0 - cap[min(F, Fmax), min(P, Pmax)]  # below 0 by rounding when all is kept
    return Orders(int(F), int(P), float(np.clip(left_out, 0.0, 1.0)), eps, bool(ok))


def search_orders(rb: ReflectionBRDF, eps: float) -> tuple[Orders, BRDFCoefficients]:
    """:func:`select_orders` on ``rb``'s coefficients to ``F_LIMIT``, ``P_LIMIT`` (``P = 0``
    radially symmetric), and those coefficients: ``reached`` is False when no ``F ≤ F_LIMIT``,
    ``P ≤ P_LIMIT`` leaves at most ``eps`` of the energy out (then ``eps_brdf`` is the best
    reachable). The rule the planner and ``shrm`` refuse an impossible tolerance by."""
    search = brdf_coefficients(rb, F_LIMIT, 0 if rb.radially_symmetric else P_LIMIT)
    return select_orders(search, eps), search
