"""Spherical Harmonic Reflection Maps by frequency-space prefiltering (Ramamoorthi & Hanrahan 2002).

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

With ``M(R_t)`` the real SH matrix (:mod:`shbake.sh.rotation`) of the
rotation ``R_t = R_z(β) R_y(α)`` taking +Z to the texel direction ``R =
(α, β)``, the local SHRM (eq. 5, 6, 14) and the global SHRM (eq. 7, 8) are::

    B_pq(R)  = Σ_l ρ̂_{l p |q|} Σ_m L_lm M^l(R_t)_{m q}         (local, view in the frame R_t)
    B̃_ps(R) = Σ_q M^p(R_t)_{s q} B_pq(R)                       (global, world view V)
    B̃(R, V) = Σ_{p ≤ P} Σ_s B̃_ps(R) y_ps(V)                      (eq. 7 / 12)

The paper's ``Λ_l`` is inside ``M``: ``M^l(R_t)_{m0} = Λ_l y_lm(R)``, so for
``q = 0`` the formula is eq. 5 ``B_lmp0 = Λ_l L_lm ρ̂_lp0`` expanded at ``R``.
``M^l(R_t) = M(R_z β) M(R_y α)`` and ``M(R_y α) = X M(R_z α) Xᵀ`` with the
constant ``X = M(R_x(−90°))`` from :class:`~shbake.sh.rotation.SHRotation`
(Ivanic–Ruedenberg, stable to ``l = 64``); only the ``2P+1`` columns
``|q| ≤ P`` of ``M(R_y α)`` are formed, once per distinct polar angle of the
cube's texels (the faces' symmetry makes them ~8× fewer than the texels),
as one matrix product per band, and shared between ``α`` and ``π − α``
(``M^l(R_y(π−α))_{kq} = (−1)^{l+|k|+|q|} sgn(k) M^l(R_y α)_{kq}``, ``sgn 0 = +1``,
measured). Per texel the cost is ``O(F² P)`` per colour.

Kinds of reparameterised BRDF:

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
``F`` at that ``P`` (appendix C). The residual-energy bound of appendix B is
reported as a check.
"""

import time
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from shbake.brdf import kajiya_kay
from shbake.brdf.dispatch import brdf_eval
from shbake.brdf.model import NO_DATA, make_brdf
from shbake.brdf.sampling import tangent_frame
from shbake.conventions import n_coeffs
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.resources import check_memory
from shbake.sh.basis import real_sh_numba
from shbake.sh.rotation import SHRotation
from shbake.texture.cube import cube_directions

F_LIMIT = 64
"""Largest ``F`` (light × BRDF band limit); the rotation is verified to ``l = 64``."""
P_LIMIT = 16
"""Largest ``P`` (view band limit)."""
FACE_MIN, FACE_MAX = 4, 1024
FACE_AUTO_MIN, FACE_AUTO_MAX = 16, 256
"""Range of the automatic face size (``--face-size`` may go from FACE_MIN to FACE_MAX)."""
BYTES_LIMIT = 2 << 30
"""Largest coefficient cube accepted (float32 bytes)."""

KINDS = ("surface", "lobe", "tangent")
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
    """

    name: str
    kind: str
    model_id: int
    prm: np.ndarray
    values: dict
    data: np.ndarray = field(default_factory=lambda: NO_DATA)
    source: str = ""

    @property
    def kind_id(self) -> int:
        return KINDS.index(self.kind)

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
                          brdf.data, brdf.source)  # fmt: skip


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
def _rho_grid(kind, model, prm, data, xi, xo, phi, out, b0, b1):
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


@lru_cache(maxsize=16)
def _gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [−1, 1] (cached: ``leggauss`` is O(n³))."""
    x, w = np.polynomial.legendre.leggauss(n)
    x.flags.writeable = w.flags.writeable = False
    return x, w


def default_quadrature(kind: str, n_theta_i: int = 320, n_theta_o: int = 64, n_phi: int = 64):
    """The quadrature used by default: ``n_theta_i`` nodes about ``R``, etc.

    Resolves lobes down to ``σ ≈ 0.05`` rad / Phong exponents ≈ 2000; radially
    symmetric lobes take one ``θ_o`` and one ``φ`` node, tangent lobes no ``φ``.
    """
    xi, wi = _gauss_legendre(n_theta_i)
    if kind == "lobe":
        xo, wo = np.array([0.0]), np.array([2.0])
    else:
        xo, wo = _gauss_legendre(n_theta_i if kind == "tangent" else n_theta_o)
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
    run_blocks(_rho_grid, quad.xi.size, grid.size * 40.0, rb.kind_id, rb.model_id,
               np.ascontiguousarray(rb.prm, dtype=float), rb.data, quad.xi, quad.xo, quad.phi,
               grid)  # fmt: skip
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


def residual_bound(L, light_energy, coeffs: BRDFCoefficients, F: int, P: int) -> dict:
    """The conservative error estimate of appendix B, per channel and worst.

    ``B_res = Λ_{F+1}² (ε_L L_tot) (ε_ρ ρ̂_tot)`` — the residual lighting and
    BRDF energies meeting in band ``F+1`` (the paper prints ``Λ_{F+1}``;
    squared here so that it is an energy like ``|B_lmpq|²``) — and
    ``ε_B ≤ B_res / (Σ |B_lmpq|² + B_res)`` with ``B_lmpq = Λ_l L_lm ρ̂_lpq``.
    ``L``: lighting coefficients to band ``F`` at least; ``light_energy``:
    ``∫ L² dω`` per channel.
    """
    L = np.asarray(L, float)[: n_coeffs(F)]
    lam2 = 4.0 * np.pi / (2.0 * np.arange(F + 2) + 1.0)
    bands = np.repeat(np.arange(F + 1), 2 * np.arange(F + 1) + 1)
    light_band = np.zeros((F + 1, 3))
    np.add.at(light_band, bands, L**2)
    eps_l_tot = np.maximum(np.asarray(light_energy, float) - light_band.sum(axis=0), 0.0)
    e = coeffs.band_energy()[: F + 1, : P + 1]  # (l, p, c)
    eps_r_tot = np.maximum(coeffs.total - e.sum(axis=(0, 1)), 0.0)
    kept = np.einsum("l,lc,lpc->c", lam2[: F + 1], light_band, e)
    b_res = lam2[F + 1] * eps_l_tot * eps_r_tot
    with np.errstate(invalid="ignore", divide="ignore"):
        eps_b = np.where(kept + b_res > 0, b_res / (kept + b_res), 0.0)
    return {
        "eps_light": (eps_l_tot / np.maximum(light_energy, 1e-300)).tolist(),
        "eps_brdf": (eps_r_tot / np.maximum(coeffs.total, 1e-300)).tolist(),
        "eps_bound": eps_b.tolist(),
        "eps_bound_max": float(np.max(eps_b)),
    }


def auto_face_size(F: int) -> int:
    """Face size from ``F``: ``S_B ≈ 10F`` texels over ``θ ∈ [0, π]`` (§5.2) is ``5F``
    per 90° face; the nearest power of two, within [16, 256]."""
    if F <= 0:
        return FACE_AUTO_MIN
    s = 2 ** int(round(np.log2(5.0 * F)))
    return int(min(max(s, FACE_AUTO_MIN), FACE_AUTO_MAX))


def check_face_size(size, P: int, kind: str) -> int:
    if isinstance(size, bool) or not isinstance(size, int | np.integer):
        raise ParameterError(f"face size must be an integer, got {size!r}")
    if not FACE_MIN <= size <= FACE_MAX:
        raise ParameterError(f"face size must be in [{FACE_MIN}, {FACE_MAX}], got {size}")
    terms = P + 1 if kind == "tangent" else (P + 1) ** 2
    nbytes = 6 * size * size * terms * 3 * 4
    if nbytes > BYTES_LIMIT:
        raise ParameterError(
            f"a {size}² × 6 SHRM with {terms} terms would take {nbytes / 2**30:.1f} GiB "
            f"(limit {BYTES_LIMIT / 2**30:.0f} GiB); lower --face-size or --P"
        )
    # the bake holds the cube in float64 and its per-texel result rows: 2 × 8 bytes a term
    check_memory(6 * size * size * terms * 3 * 8 * 2,
                 f"a {size}² × 6 SHRM with {terms} terms")  # fmt: skip
    return int(size)


# ---------------------------------------------------------------------------------------------
# Step 3 of appendix C: the SHRM on the cube


def _x_blocks(F: int) -> list[np.ndarray]:
    """Blocks of ``X = M(R_x(−90°))``: ``M(R_y α) = X M(R_z α) Xᵀ``."""
    rx = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    rot = SHRotation(rx, F)
    return [rot.block(l).copy() for l in range(F + 1)]


def ry_columns(cos_a, sin_a, F: int, Q: int, X=None) -> np.ndarray:
    """Columns ``|q| ≤ min(l, Q)`` of ``M^l(R_y α)`` for ``l ≤ F`` at many angles.

    Returns ``(n, 2Q+1, (F+1)²)``: entry ``[a, q+Q, l(l+1)+k]`` is
    ``M^l(R_y α_a)_{k q}`` (zero for ``|q| > l``). ``M(R_y α) = X M(R_z α) Xᵀ``
    is formed as one matrix product per band over all angles.
    """
    ca = np.asarray(cos_a, float)
    sa = np.asarray(sin_a, float)
    n = ca.size
    if Q == 0:  # M^l(R_y α)_{k0} = Λ_l y_lk(R_y ẑ), R_y ẑ = (sin α, 0, cos α): O(F²) per angle
        lam = np.sqrt(4.0 * np.pi / (2.0 * np.arange(F + 1) + 1.0))
        y = real_sh_numba(np.stack([sa, np.zeros_like(sa), ca], axis=-1), F)
        return (y * np.repeat(lam, 2 * np.arange(F + 1) + 1))[:, None, :]
    X = X if X is not None else _x_blocks(F)
    out = np.zeros((n, 2 * Q + 1, n_coeffs(F)))
    ang = np.arctan2(sa, ca)
    k = np.arange(F + 1)
    ck, sk = np.cos(k[:, None] * ang[None, :]), np.sin(k[:, None] * ang[None, :])  # (k, n)
    for l in range(F + 1):
        qq = min(l, Q)
        Xl = X[l]
        W = Xl[l - qq : l + qq + 1, :].T  # (2l+1, 2qq+1): columns q of Xᵀ
        Z = np.empty((2 * l + 1, n, 2 * qq + 1))
        Z[l] = W[l]
        if l:
            c, s = ck[1 : l + 1, :, None], sk[1 : l + 1, :, None]
            wp, wm = W[l + 1 :, None, :], W[l - 1 :: -1, None, :]
            Z[l + 1 :] = c * wp - s * wm
            Z[l - 1 :: -1] = s * wp + c * wm
        Y = (Xl @ Z.reshape(2 * l + 1, -1)).reshape(2 * l + 1, n, 2 * qq + 1)
        out[:, Q - qq : Q + qq + 1, l * l : (l + 1) ** 2] = Y.transpose(1, 2, 0)
    return out


@jit
def _ysign(flip, l, k, q):
    """Sign taking ``M^l(R_y α)_{kq}`` to ``M^l(R_y(π − α))_{kq}``: ``(−1)^{l+|k|+|q|} sgn k``."""
    if not flip:
        return 1.0
    s = 1.0 if (l + abs(k) + abs(q)) % 2 == 0 else -1.0
    return s if k >= 0 else -s


TEXEL_BLOCK = 64
"""Texels per block of :func:`_shrm_texels`: they share its scratch arrays; the unit
:func:`~shbake.jit.run_blocks` hands to a thread."""


@jit
def _shrm_texels(aidx, flip, cb, sb, Y, L, rho, F, P, Q, mode, out, b0, b1):
    """Per texel: rotate the lighting by β, contract with the ``R_y α`` columns, sum over ``l``
    with ``ρ̂`` (local SHRM), then rotate the view index (global SHRM, ``mode = 0``),
    keep it local (``mode = 1``) or keep ``q = 0`` only (tangent, ``mode = 2``).

    ``M(R_y α)`` keeps the parity of the real basis (``cos`` ↔ ``cos``, ``sin`` ↔ ``sin``):
    ``Y[a, q, k] = 0`` when ``k`` and ``q`` differ in sign, so half the sums are skipped.
    Texels with ``flip[t]`` read the columns of ``π − α`` and apply :func:`_ysign`.
    Texels are processed in blocks of :data:`TEXEL_BLOCK` that share their scratch arrays;
    this call does blocks ``b0 … b1 − 1``.
    """
    n = aidx.shape[0]
    block = TEXEL_BLOCK
    for blk in range(b0, b1):
        ck = np.empty(F + 1)
        sk = np.empty(F + 1)
        G = np.empty((F + 1, 2 * Q + 1, 3))
        B = np.zeros((P + 1, 2 * P + 1, 3))
        for t in range(blk * block, min(n, (blk + 1) * block)):
            _texel(t, aidx[t], flip[t], cb[t], sb[t], Y, L, rho, F, P, Q, mode, ck, sk, G, B,
                   out)  # fmt: skip


@jit
def _texel(t, a, fl, cbt, sbt, Y, L, rho, F, P, Q, mode, ck, sk, G, B, out):
    ck[0], sk[0] = 1.0, 0.0
    for k in range(1, F + 1):
        ck[k] = ck[k - 1] * cbt - sk[k - 1] * sbt
        sk[k] = sk[k - 1] * cbt + ck[k - 1] * sbt
    G[:] = 0.0
    for l in range(F + 1):
        base = l * (l + 1)
        qq = min(l, Q)
        for k in range(0, l + 1):  # cos-type: (M(R_z β)ᵀ L)_k, k ≥ 0, meets q ≥ 0
            if k == 0:
                r0, r1, r2 = L[base, 0], L[base, 1], L[base, 2]
            else:
                c, s = ck[k], sk[k]
                r0 = c * L[base + k, 0] + s * L[base - k, 0]
                r1 = c * L[base + k, 1] + s * L[base - k, 1]
                r2 = c * L[base + k, 2] + s * L[base - k, 2]
            for q in range(0, qq + 1):
                y = Y[a, q + Q, base + k] * _ysign(fl, l, k, q)
                G[l, q + Q, 0] += y * r0
                G[l, q + Q, 1] += y * r1
                G[l, q + Q, 2] += y * r2
        if qq == 0:
            continue
        for k in range(1, l + 1):  # sin-type: index −k, meets q < 0
            c, s = ck[k], sk[k]
            r0 = -s * L[base + k, 0] + c * L[base - k, 0]
            r1 = -s * L[base + k, 1] + c * L[base - k, 1]
            r2 = -s * L[base + k, 2] + c * L[base - k, 2]
            for q in range(-qq, 0):
                y = Y[a, q + Q, base - k] * _ysign(fl, l, -k, q)
                G[l, q + Q, 0] += y * r0
                G[l, q + Q, 1] += y * r1
                G[l, q + Q, 2] += y * r2
    for p in range(P + 1):
        qq = min(p, Q)
        for q in range(-qq, qq + 1):
            aq = abs(q)
            for c in range(3):
                acc = 0.0
                for l in range(aq, F + 1):
                    acc += rho[l, p, aq, c] * G[l, q + Q, c]
                B[p, q + P, c] = acc
    for c in range(3):
        if mode == 2:
            for p in range(P + 1):
                out[t, p, c] = B[p, P, c]
        elif mode == 1 or Q == 0:
            for p in range(P + 1):
                for q in range(-p, p + 1):
                    out[t, p * (p + 1) + q, c] = B[p, q + P, c] if abs(q) <= Q else 0.0
        else:
            for p in range(P + 1):
                base = p * (p + 1)
                for s in range(-p, p + 1):
                    acc = 0.0
                    for q in range(-p, p + 1):
                        ys = abs(s)
                        yp = Y[a, q + Q, base + ys] * _ysign(fl, p, ys, q)
                        ym = Y[a, q + Q, base - ys] * _ysign(fl, p, -ys, q)
                        if s == 0:
                            m = yp
                        elif s > 0:
                            m = ck[s] * yp - sk[s] * ym
                        else:
                            m = sk[-s] * yp + ck[-s] * ym
                        acc += m * B[p, q + P, c]
                    out[t, base + s, c] = acc


def shrm_from_directions(
    dirs, L, coeffs: BRDFCoefficients, kind: str = "surface", local: bool = False,
    chunk_bytes: int = 48 << 20,
) -> np.ndarray:  # fmt: skip
    """SHRM coefficients at texel directions ``dirs (N, 3)`` (world = SH frame).

    Returns ``(N, (P+1)², 3)`` — the global SHRM ``B̃_ps`` (or the local
    ``B_pq`` with ``local=True``) — or ``(N, P+1, 3)`` ``B_p0`` for the
    tangent kind. ``L``: world lighting coefficients ``((F+1)², 3)`` at least.
    """
    F, P = coeffs.F, coeffs.P
    Q = P if kind == "surface" else 0
    mode = 2 if kind == "tangent" else (1 if local else 0)
    d = np.asarray(dirs, float).reshape(-1, 3)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    ca = np.clip(d[:, 2], -1.0, 1.0)
    sa = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        cb = np.where(sa > 0, d[:, 0] / np.where(sa > 0, sa, 1.0), 1.0)
        sb = np.where(sa > 0, d[:, 1] / np.where(sa > 0, sa, 1.0), 0.0)
    flip = ca < 0.0  # read the columns of π − α (one table for both hemispheres)
    keys = np.round(np.abs(ca) * 2.0**40).astype(np.int64)
    uniq, first, inv = np.unique(keys, return_index=True, return_inverse=True)
    inv = inv.ravel()
    n_out = P + 1 if kind == "tangent" else n_coeffs(P)
    out = np.zeros((d.shape[0], n_out, 3))
    X = _x_blocks(F) if Q > 0 else None
    Lc = np.ascontiguousarray(np.asarray(L, float)[: n_coeffs(F)])
    rho = np.ascontiguousarray(coeffs.rho)
    row_bytes = n_coeffs(F) * (2 * Q + 1) * 8
    per = max(1, chunk_bytes // row_bytes)
    order = np.argsort(inv, kind="stable")
    bounds = np.searchsorted(inv[order], np.arange(0, uniq.size + per, per))
    for c0 in range(0, uniq.size, per):
        c1 = min(c0 + per, uniq.size)
        rep = first[c0:c1]
        Y = np.ascontiguousarray(ry_columns(np.abs(ca[rep]), sa[rep], F, Q, X))
        sel = order[bounds[c0 // per] : bounds[c0 // per + 1]]
        if sel.size == 0:
            continue
        res = np.zeros((sel.size, n_out, 3))
        run_blocks(_shrm_texels, -(-sel.size // TEXEL_BLOCK), sel.size * res[0].size * F * 8.0,
                   np.ascontiguousarray(inv[sel] - c0), np.ascontiguousarray(flip[sel]),
                   np.ascontiguousarray(cb[sel]),
                   np.ascontiguousarray(sb[sel]), Y, Lc, rho, F, P, Q, mode, res)  # fmt: skip
        out[sel] = res
    return out


def shrm_cube(L, coeffs: BRDFCoefficients, face_size: int, kind: str = "surface",
              local: bool = False) -> np.ndarray:  # fmt: skip
    """The SHRM on a cube map: ``(6, S, S, (P+1)², 3)`` (``(6, S, S, P+1, 3)`` tangent)."""
    dirs = cube_directions(face_size)
    flat = shrm_from_directions(dirs.reshape(-1, 3), L, coeffs, kind, local)
    return flat.reshape(6, face_size, face_size, *flat.shape[1:])


# ---------------------------------------------------------------------------------------------
# The bake


@dataclass
class ShrmBake:
    """A baked SHRM and everything its asset records.

    ``cube`` float32 ``(6, S, S, (P+1)², 3)`` (tangent: ``P+1`` terms);
    ``coeffs`` the BRDF coefficients at ``(F, P)``; ``timings`` seconds per
    step (``brdf``, ``light``, ``shrm``, ``total``).
    """

    cube: np.ndarray
    brdf: ReflectionBRDF
    orders: Orders
    face_size: int
    coeffs: BRDFCoefficients
    bound: dict
    timings: dict
    light: np.ndarray

    @property
    def F(self) -> int:
        return self.orders.F

    @property
    def P(self) -> int:
        return self.orders.P


def bake_shrm(env, rb: ReflectionBRDF, eps: float = 0.03, F=None, P=None, face_size=None,
              coeffs_full: BRDFCoefficients | None = None, rotation=None) -> ShrmBake:  # fmt: skip
    """Bake the global SHRM of ``env`` (an :class:`~shbake.envmap.Environment`) for ``rb``.

    Orders from ``eps`` unless ``F``/``P`` are given (:func:`select_orders`);
    face size from ``F`` unless given (:func:`auto_face_size`). ``coeffs_full``
    may pass precomputed coefficients to ``(F_LIMIT, P_search)`` (benchmarks).
    ``rotation``: turn the environment by ``R`` first (a scene probe's pose,
    :mod:`shbake.envmap.turn`): the lighting becomes ``M(R) L``, exactly.
    """
    eps = check_eps(eps)
    F, P = check_F(F), check_P(P)
    if rb.radially_symmetric:
        if P not in (None, 0):
            raise ParameterError(f"{rb.name} is radially symmetric: P must be 0, got {P}")
        P = 0
    t0 = time.perf_counter()
    if coeffs_full is None:
        f_search = F if F is not None else F_LIMIT
        p_search = P if P is not None else (0 if rb.radially_symmetric else P_LIMIT)
        coeffs_full = brdf_coefficients(rb, f_search, p_search)
    orders = select_orders(coeffs_full, eps, F, P)
    coeffs = coeffs_full.truncated(orders.F, orders.P)
    t1 = time.perf_counter()
    size = auto_face_size(orders.F) if face_size is None else face_size
    size = check_face_size(size, orders.P, rb.kind)
    L = env.project(orders.F)
    if rotation is not None:
        from shbake.sh.rotation import rotate

        L = rotate(L, rotation)
    light_energy = np.einsum("hwc,hw->c", env.pixels.astype(np.float64) ** 2,
                             env.quadrature_weights())  # fmt: skip
    t2 = time.perf_counter()
    cube = shrm_cube(L, coeffs, size, rb.kind)
    t3 = time.perf_counter()
    bound = residual_bound(L, light_energy, coeffs, orders.F, orders.P)
    timings = {"brdf": t1 - t0, "light": t2 - t1, "shrm": t3 - t2, "total": t3 - t0}
    return ShrmBake(cube.astype(np.float32), rb, orders, size, coeffs, bound, timings, L)


# ---------------------------------------------------------------------------------------------
# Files: the asset, the EXR cubes, the --report table


def parse_view(text) -> np.ndarray:
    """A view direction ``"x,y,z"`` (world, toward the viewer), normalised."""
    try:
        v = np.array([float(x) for x in str(text).split(",")], dtype=float)
    except ValueError:
        raise ParameterError(f"view must be x,y,z numbers, got {text!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) == 0.0:
        raise ParameterError(f"view must be a non-zero x,y,z vector, got {text!r}")
    return v / np.linalg.norm(v)


def write_exr_cubes(directory: str, bake: ShrmBake, view, png: bool = False) -> list[str]:
    """``shrm_p{p}.exr`` per ``p`` (channels ``q{q}.R/G/B``; tangent kind: ``R/G/B`` of
    ``B_p0``) and ``reflection.exr`` (eq. 12 for ``view``), OpenEXR cube strips (float32);
    with ``png`` a PNG beside each: the ``q`` components (channel mean) side by side, and the
    reflection tone-mapped."""
    import os

    from shbake.format.atomic import makedirs
    from shbake.format.images import component_strip, tonemap_to_srgb8, write_exr, write_png
    from shbake.shading.shrm import reflection_cube

    makedirs(directory)
    S = bake.face_size
    written = []
    for p in range(bake.P + 1):
        if bake.brdf.kind == "tangent":
            img = bake.cube[:, :, :, p, :]
            names = ("R", "G", "B")
        else:
            img = bake.cube[:, :, :, p * p : (p + 1) ** 2, :].reshape(6, S, S, -1)
            names = tuple(f"q{q}.{c}" for q in range(-p, p + 1) for c in "RGB")
        path = os.path.join(directory, f"shrm_p{p}.exr")
        write_exr(path, img.reshape(6 * S, S, -1), half=False, attrs={"envmap": "cube"},
                  channel_names=names)  # fmt: skip
        written.append(path)
        if png:
            written.append(os.path.join(directory, f"shrm_p{p}.png"))
            write_png(written[-1], component_strip(img.reshape(6 * S, S, -1, 3).mean(axis=-1)))
    kind = "tangent" if bake.brdf.kind == "tangent" else "surface"
    refl = reflection_cube(bake.cube, view, kind)
    path = os.path.join(directory, "reflection.exr")
    write_exr(path, refl.reshape(6 * S, S, 3), half=False, attrs={"envmap": "cube"})
    written.append(path)
    if png:
        written.append(os.path.join(directory, "reflection.png"))
        write_png(written[-1], tonemap_to_srgb8(refl.reshape(6 * S, S, 3)))
    return written


class ShadingCheck:
    """Brute-force shading of a sphere seen from +Z (the preview's orthographic sphere,
    ``sphere × sphere`` pixels) under ``env`` turned by ``rotation``, to measure an SHRM
    against: ``ref`` is ``None`` for the tangent kind (no surface to shade).

    Surface kinds: :func:`shbake.reference.brdf_shading.brute_force_shading` of the BRDF
    over every texel; the lobe kind: the radially symmetric Phong lobe summed over texels.
    """

    def __init__(self, env, rb: ReflectionBRDF, sphere: int = 24, rotation=None):
        from shbake.brdf.sampling import tangent_frame as frame_of
        from shbake.reference.brdf_shading import brute_force_shading

        c = 2.0 * (np.arange(sphere) + 0.5) / sphere - 1.0
        x, y = np.meshgrid(c, -c)
        inside = x * x + y * y < 1.0
        n = np.stack([x[inside], y[inside], np.sqrt(1.0 - x[inside] ** 2 - y[inside] ** 2)], -1)
        self.normals, self.view, self.kind = n, np.array([0.0, 0.0, 1.0]), rb.kind
        self.ref = None
        dirs, om, rad = env.samples()
        if rotation is not None:
            dirs = dirs @ np.asarray(rotation).T  # the map's d is seen at R d
        view = self.view
        if rb.kind == "surface":
            frames = np.array([np.array([*frame_of(*x), x]) for x in n])
            brdf = make_brdf(rb.name, rb.source or None, **_plain(rb.values))
            self.ref = brute_force_shading(dirs, om, rad, frames,
                                           np.einsum("pij,j->pi", frames, view), brdf)  # fmt: skip
        elif rb.kind == "lobe":
            r = 2.0 * n[:, 2:3] * n - view
            s = rb.values["s"]
            ref = np.zeros((len(r), 3))
            for i in range(0, len(r), 64):
                cz = np.clip(r[i : i + 64] @ dirs.T, 0.0, None)
                ref[i : i + 64] = ((s + 1) / (2 * np.pi) * cz**s * om) @ rad / np.sqrt(4 * np.pi)
            self.ref = ref

    def rel_energy(self, cube: np.ndarray) -> float:
        """``Σ (shaded − ref)² / Σ ref²`` of the SHRM ``cube`` (comparable with ``eps_brdf``)."""
        from shbake.shading.shrm import reflection_cube, shade

        img = shade(reflection_cube(cube, self.view), self.normals, self.view)
        return float(np.sum((img - self.ref) ** 2) / max(float(np.sum(self.ref**2)), 1e-300))


def report_rows(env, rb: ReflectionBRDF, F_values, P_values, face_size: int = 32,
                sphere: int = 24) -> list[dict]:  # fmt: skip
    """The ``--report`` table: per ``(F, P)`` the predicted error (BRDF energy left out and
    the appendix-B bound, both energy fractions), the error measured against brute force on
    a sphere seen from +Z (relative RMS, and its square, the relative energy; surface and
    lobe kinds), the bake time and the bytes."""
    F_values, P_values = list(F_values), list(P_values)
    if rb.radially_symmetric:
        P_values = [0]
    co = brdf_coefficients(rb, max(F_values), max(P_values))
    check = ShadingCheck(env, rb, sphere)
    rows = []
    for F in F_values:
        for P in P_values:
            b = bake_shrm(env, rb, eps=0.5, F=F, P=P, face_size=face_size, coeffs_full=co)
            row = {"F": F, "P": P, "eps_brdf": b.orders.eps_brdf,
                   "eps_bound": b.bound["eps_bound_max"], "seconds": b.timings["total"],
                   "bytes": int(b.cube.nbytes), "measured_rel_rms": None,
                   "measured_rel_energy": None}  # fmt: skip
            if check.ref is not None:
                e2 = check.rel_energy(b.cube)
                row["measured_rel_rms"] = float(np.sqrt(e2))
                row["measured_rel_energy"] = e2  # comparable with eps_brdf and the bound
            rows.append(row)
    return rows


def _plain(values: dict) -> dict:
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in values.items()}


@dataclass
class ShrmSettings:
    """The checked settings of one ``shrm`` bake (:func:`shrm_settings`); ``search``: the
    coefficients to the limits the orders are chosen from (``None`` when ``F`` or ``P`` is
    given)."""

    rb: ReflectionBRDF
    eps: float
    F: int | None
    P: int | None
    face_size: int | None
    view: np.ndarray
    search: BRDFCoefficients | None


def shrm_settings(brdf: str = "microfacet", params: dict | None = None,
                  merl_path: str | None = None, eps: float = 0.03, F=None, P=None,
                  face_size=None, view="0,0,1") -> ShrmSettings:  # fmt: skip
    """Every setting of the ``shrm`` command checked before a map is read; a
    :class:`~shbake.errors.ParameterError` names the first bad one (the CLI's usage error).

    With neither ``F`` nor ``P`` given, an ``eps`` no ``F ≤ F_LIMIT``, ``P ≤ P_LIMIT``
    reaches is refused (:func:`search_orders`, as the planner refuses it), naming the best
    reachable.
    """
    eps = check_eps(eps)
    F, P = check_F(F), check_P(P)
    rb = make_reflection_brdf(brdf, params, merl_path)
    if rb.radially_symmetric and P not in (None, 0):
        raise ParameterError(f"{rb.name} is radially symmetric: P must be 0, got {P}")
    if face_size is not None:
        check_face_size(face_size, P or 0, rb.kind)
    v = parse_view(view)
    search = None
    if F is None and P is None:
        orders, search = search_orders(rb, eps)
        if not orders.reached:
            raise ParameterError(
                f"eps {eps:g} is not reachable for {rb.name} within F ≤ {F_LIMIT}, P ≤ "
                f"{P_LIMIT}: the best leaves {orders.eps_brdf:.3g} of the BRDF energy out; "
                "give a larger --eps, or --F/--P to bake at given orders"
            )
    return ShrmSettings(rb, eps, F, P, face_size, v, search)


def bake_to_file(env_path: str, output: str, settings: ShrmSettings, exr_dir: str | None = None,
                 report: bool = False, layout=None, colorspace=None, negative: str = "clamp",
                 fix_nonfinite=None, quiet: bool = False, png: bool = False) -> dict:  # fmt: skip
    """The ``shbake shrm`` command: load the map, bake at ``settings`` (checked before, by
    :func:`shrm_settings`), write the asset (and the EXR cubes, with ``png`` PNGs beside them),
    optionally build the report; return the summary dict."""
    from shbake.envmap import load_environment
    from shbake.format.atomic import check_output_dir, check_writable_dir
    from shbake.format.shrm import build_shrm_asset, write_shrm

    check_writable_dir(output)
    if exr_dir:
        check_output_dir(exr_dir, "--exr-dir")
    rb, eps, F, P = settings.rb, settings.eps, settings.F, settings.P
    env = load_environment(env_path, layout, colorspace, negative, fix_nonfinite, quiet)
    bake = bake_shrm(env, rb, eps, F, P, settings.face_size, coeffs_full=settings.search)
    asset = build_shrm_asset(bake, env.meta)
    write_shrm(output, asset)
    summary = {
        "output": output, "brdf": rb.describe(), "F": bake.F, "P": bake.P, "eps": eps,
        "eps_brdf": bake.orders.eps_brdf, "eps_reached": bake.orders.reached,
        "eps_bound": bake.bound["eps_bound_max"], "face_size": bake.face_size,
        "bytes": int(bake.cube.nbytes), "seconds": bake.timings,
    }  # fmt: skip
    if exr_dir:
        summary["exr"] = write_exr_cubes(exr_dir, bake, settings.view, png)
    if report:
        Fs = sorted({max(1, bake.F // 2), max(1, (3 * bake.F) // 4), bake.F,
                     min(F_LIMIT, bake.F + bake.F // 2)})  # fmt: skip
        Ps = sorted({0, max(0, bake.P - 1), bake.P, min(P_LIMIT, bake.P + 1)})
        summary["report"] = report_rows(env, rb, Fs, Ps, face_size=min(bake.face_size, 64))
    return summary
