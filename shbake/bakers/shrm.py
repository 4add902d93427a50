"""Spherical Harmonic Reflection Maps by frequency-space prefiltering (Ramamoorthi & Hanrahan 2002).

The BRDF's coefficients ``ρ̂_lpq`` and the orders ``F``, ``P`` come from
:mod:`shbake.brdf.reflection` (the reparameterised BRDF, RH02 eq. 13, §5.1). With
``M(R_t)`` the real SH matrix (:mod:`shbake.sh.rotation`) of the
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
measured). Per texel the cost is ``O(F² P)`` per colour. The residual-energy bound of
appendix B is reported as a check.
"""

import time
from dataclasses import dataclass

import numpy as np

from shbake.brdf.reflection import (
    F_LIMIT,
    P_LIMIT,
    BRDFCoefficients,
    Orders,
    ReflectionBRDF,
    brdf_coefficients,
    check_eps,
    check_F,
    check_P,
    select_orders,
)
from shbake.conventions import n_coeffs, to_float32
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.resources import check_memory
from shbake.sh.basis import real_sh_numba
from shbake.sh.rotation import SHRotation
from shbake.texture.cube import cube_directions

FACE_MIN, FACE_MAX = 4, 1024
FACE_AUTO_MIN, FACE_AUTO_MAX = 16, 256
"""Range of the automatic face size (``--face-size`` may go from FACE_MIN to FACE_MAX)."""
BYTES_LIMIT = 2 << 30
"""Largest coefficient cube accepted (float32 bytes)."""


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
    :mod:`shbake.envmap.turn`): the lighting becomes ``M(R) L``, exactly. A cube whose
    coefficients float32 cannot hold (a map near the float32 limit: a constant map's ``L_00``
    is ``√(4π)`` times its radiance) is refused in one line naming the map
    (:func:`~shbake.conventions.to_float32`).
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
    stored = to_float32(cube, env.meta.get("path", "the map"), "the SHRM projection")
    bound = residual_bound(L, light_energy, coeffs, orders.F, orders.P)
    timings = {"brdf": t1 - t0, "light": t2 - t1, "shrm": t3 - t2, "total": t3 - t0}
    return ShrmBake(stored, rb, orders, size, coeffs, bound, timings, L)
