"""SH-exponential glossy probe shading (Silvennoinen et al. 2025, §4; shbake's v2).

``E0(v, n, α) ≈ P(ρ, α) Q(h_ρ, α)`` (eq. 9–11) with ``ρ = 2(n·v)n − v`` the
mirror direction, ``h_ρ = (n + ρ)/|n + ρ|``, ``α`` the GGX width (SPEC §1), and::

    P = exp(Σ_lm vMF_l(1/α) y_lm(ρ) p_lm(α)),  Q = exp(Σ_lm vMF_l(1/α) y_lm(h_ρ) q_lm(α))
    vMF_l(κ) = exp(−l(l+1)/(2κ))  so  vMF_l(1/α) = exp(−l(l+1) α / 2)   (eq. 12)

``q`` has no DC term. The paper has one set ``(p, q)`` for every ``α``
(``K = 1``). v2 stores ``K`` sets at knots ``α_0 < … < α_{K−1}`` and blends
them with piecewise-linear hat functions of ``α`` (``K = 2``: linear in
``α``), ``p(α) = Σ_k h_k(α) p_k``; ``α`` is clamped to the knots, so the
coefficients are continuous in ``α`` (no seam). Full radiance
``E = F0 E0 + (1 − F0) E1`` (eq. 5) with the Fresnel tail read as the split-sum reads it::

    E1 = P(ρ, α) Q(ρ, α) · A1(n·v, α) / A0(1, α)

``P(ρ) Q(ρ)`` is the probe's ``E0`` at normal incidence about the mirror direction
(``n = v = ρ``, where ``h_ρ = ρ``): the lobe's radiance ``E0(ρ, ρ)/A0(1)`` times the tail's
DFG term (:mod:`shbake.shading.dfg`); exact under constant light, like the paper's eq. 15
(``E1 = E0 A1/A0``), which it replaces: eq. 15 carries ``E0``'s grazing lobe into the tail
and overestimates it there (docs/BENCHMARKS.md, probe evaluation). Fitted by
:mod:`shbake.bakers.shexp`.
"""

import numpy as np

from shbake.conventions import DFG_SIZE, lmax_of
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.basis import (
    BLOCK,
    add_sums,
    recurrence_tables,
    sh_eval_into,
    sum_scratch,
    sum_weights,
)
from shbake.shading.dfg import dfg_at
from shbake.shading.shader import Shader, Texture, Uniform


def vmf_factors(lmax: int, alpha) -> np.ndarray:
    """``vMF_l(1/α) = exp(−l(l+1)α/2)`` per coefficient index, ``(…, (lmax+1)^2)`` (eq. 12)."""
    l = np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
    a = np.asarray(alpha, dtype=float)[..., None]
    return np.exp(-l * (l + 1) * a / 2.0)


@jit
def hat_weight(knots, alpha, k):
    """Weight of set ``k`` at ``α``: the piecewise-linear hat on ``knots`` (check-free).

    ``α`` is clamped to ``[knots[0], knots[-1]]``; one knot gives weight 1.
    """
    n = knots.shape[0]
    if n == 1:
        return 1.0
    a = min(max(alpha, knots[0]), knots[n - 1])
    if k > 0 and knots[k - 1] <= a <= knots[k]:
        return (a - knots[k - 1]) / (knots[k] - knots[k - 1])
    if k < n - 1 and knots[k] <= a <= knots[k + 1]:
        return (knots[k + 1] - a) / (knots[k + 1] - knots[k])
    return 0.0


def hat_weights(knots, alpha) -> np.ndarray:
    """``(T, K)`` hat weights of every set at each ``α`` (:func:`hat_weight`)."""
    knots = np.asarray(knots, dtype=float)
    a = np.clip(np.asarray(alpha, dtype=float).reshape(-1), knots[0], knots[-1])
    out = np.zeros((a.size, knots.size))
    if knots.size == 1:
        out[:] = 1.0
        return out
    i = np.clip(np.searchsorted(knots, a, side="right") - 1, 0, knots.size - 2)
    t = (a - knots[i]) / (knots[i + 1] - knots[i])
    rows = np.arange(a.size)
    out[rows, i] = 1.0 - t
    out[rows, i + 1] += t
    return out


def mirror_and_half(views, normals) -> tuple[np.ndarray, np.ndarray]:
    """``ρ = 2(n·v)n − v`` and ``h_ρ = (n + ρ)/|n + ρ|`` (eq. 10)."""
    nv = np.einsum("...i,...i->...", normals, views)[..., None]
    rho = 2.0 * nv * normals - views
    h = normals + rho
    return rho, h / np.linalg.norm(h, axis=-1, keepdims=True)


PIXEL_BLOCK = 256
"""Shading points per work item of :func:`evaluate_shexp` (scratch is allocated once per
range of items, never per point)."""


@jit
def _evaluate_blocks(views, normals, alphas, f0, p, q, knots, lmax_p, lmax_q, qmm, a, b, table,
                     out, b0, b1):  # fmt: skip
    """Points ``b0·PIXEL_BLOCK … b1·PIXEL_BLOCK − 1`` of :func:`evaluate_shexp` (check-free).

    Per distinct ``α`` (a run of equal ``α`` reuses them): the hat-blended
    coefficients ``Σ_k h_k(α) p_k`` times the vMF factor ``exp(−l(l+1)α/2)``
    of their band (eq. 12), computed once per band. Per point: the SH
    evaluations (``P`` at ``ρ``, ``Q`` at ``h_ρ`` and at ``ρ`` for the tail), the sums
    (independent chains per channel), ``exp`` and the DFG terms.
    """
    n_sets = knots.shape[0]
    n_p = (lmax_p + 1) ** 2
    n_q = (lmax_q + 1) ** 2
    lmax_r = max(lmax_p, lmax_q)
    yr = np.empty((lmax_r + 1) ** 2)  # the basis at ρ: P's terms and the tail's Q terms
    yq = np.empty(n_q)
    hw = np.empty(n_sets)
    cp = np.empty((n_p, 3))
    cq = np.empty((n_q, 3))
    al_prev = np.nan
    a0n = 0.0
    for k in range(b0 * PIXEL_BLOCK, min(views.shape[0], b1 * PIXEL_BLOCK)):
        vx, vy, vz = views[k, 0], views[k, 1], views[k, 2]
        nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
        nv = nx * vx + ny * vy + nz * vz
        rx, ry, rz = 2 * nv * nx - vx, 2 * nv * ny - vy, 2 * nv * nz - vz
        hx, hy, hz = nx + rx, ny + ry, nz + rz
        hn = np.sqrt(hx * hx + hy * hy + hz * hz)
        sh_eval_into(rx, ry, rz, lmax_r, qmm, a, b, yr)
        sh_eval_into(hx / hn, hy / hn, hz / hn, lmax_q, qmm, a, b, yq)
        al = alphas[k]
        if al != al_prev:
            al_prev = al
            a0n = dfg_at(table, 1.0, al)[0]
            for s in range(n_sets):
                hw[s] = hat_weight(knots, al, s)
            for l in range(max(lmax_p, lmax_q) + 1):
                g = np.exp(-l * (l + 1) * al / 2.0)
                for i in range(l * l, (l + 1) * (l + 1)):
                    for c in range(3):
                        if i < n_p:
                            coef = 0.0
                            for s in range(n_sets):
                                coef += hw[s] * p[s, i, c]
                            cp[i, c] = g * coef
                        if 0 < i < n_q:
                            coef = 0.0
                            for s in range(n_sets):
                                coef += hw[s] * q[s, i - 1, c]
                            cq[i, c] = g * coef
        a1 = dfg_at(table, nv, al)[1]
        tail = a1 / a0n if a0n > 0.0 else 0.0
        # independent sums (P, Q and the tail's Q, per channel): not one serial chain
        p0 = p1 = p2 = q0 = q1 = q2 = r0 = r1 = r2 = 0.0
        for i in range(n_p):
            y = yr[i]
            p0 += y * cp[i, 0]
            p1 += y * cp[i, 1]
            p2 += y * cp[i, 2]
        for i in range(1, n_q):
            y = yq[i]
            q0 += y * cq[i, 0]
            q1 += y * cq[i, 1]
            q2 += y * cq[i, 2]
            y = yr[i]
            r0 += y * cq[i, 0]
            r1 += y * cq[i, 1]
            r2 += y * cq[i, 2]
        out[k, 0] = f0[0] * np.exp(p0 + q0) + (1.0 - f0[0]) * np.exp(p0 + r0) * tail
        out[k, 1] = f0[1] * np.exp(p1 + q1) + (1.0 - f0[1]) * np.exp(p1 + r1) * tail
        out[k, 2] = f0[2] * np.exp(p2 + q2) + (1.0 - f0[2]) * np.exp(p2 + r2) * tail


@jit
def _evaluate_blocks_one_alpha(views, normals, alpha, f0, wp, wq, lmax_p, lmax_q, table, out,
                               bad, b0, b1):  # fmt: skip
    """Points of blocks ``b0 … b1-1`` (:data:`~shbake.sh.basis.BLOCK` each) of
    :func:`evaluate_shexp` at one ``α`` (check-free).

    The blended, vMF-filtered coefficients are constant, so ``log P + log Q``
    of a block is fused SH sums (:func:`~shbake.sh.basis.add_sums`: vectorised
    across the block's ``ρ``, then ``Q`` at ``ρ`` for the tail, then at ``h_ρ``; no
    basis stored); per point only ``exp`` and the DFG terms remain. ``bad[blk]``
    counts the points whose ``n + ρ`` vanishes (``v = −n``).
    """
    n = views.shape[0]
    s = sum_scratch()
    dirs = np.empty((BLOCK, 3))
    acc = np.empty((BLOCK, 3))
    tail_acc = np.empty((BLOCK, 3))
    nvs = np.empty(BLOCK)
    a0n = dfg_at(table, 1.0, alpha)[0]
    for blk in range(b0, b1):
        i0 = blk * BLOCK
        nb = min(BLOCK, n - i0)
        for k in range(nb):
            i = i0 + k
            nv = normals[i, 0] * views[i, 0] + normals[i, 1] * views[i, 1]
            nv += normals[i, 2] * views[i, 2]
            nvs[k] = nv
            for c in range(3):
                dirs[k, c] = 2 * nv * normals[i, c] - views[i, c]  # ρ
                acc[k, c] = 0.0
        bad[blk] = add_sums(dirs, nb, wp, lmax_p, s, acc)
        for k in range(nb):
            for c in range(3):
                tail_acc[k, c] = acc[k, c]
        add_sums(dirs, nb, wq, lmax_q, s, tail_acc)  # Q at ρ: the tail's E0(ρ, ρ)
        for k in range(nb):
            for c in range(3):
                dirs[k, c] += normals[i0 + k, c]  # n + ρ: add_sums normalises it
        bad[blk] += add_sums(dirs, nb, wq, lmax_q, s, acc)
        for k in range(nb):
            a1 = dfg_at(table, nvs[k], alpha)[1]
            tail = a1 / a0n if a0n > 0.0 else 0.0
            for c in range(3):
                out[i0 + k, c] = (f0[c] * np.exp(acc[k, c])
                                  + (1.0 - f0[c]) * np.exp(tail_acc[k, c]) * tail)  # fmt: skip


def blended_coefficients(p, q, knots, alpha, lmax_p, lmax_q) -> tuple[np.ndarray, np.ndarray]:
    """``vMF_l(1/α) Σ_k h_k(α) p_k`` and the same of ``q`` with its DC row (zero) restored:
    ``((lmax_p+1)², 3)``, ``((lmax_q+1)², 3)`` at one ``α`` (eq. 12; the hat blend)."""
    hw = hat_weights(knots, alpha)[0]
    cp = vmf_factors(lmax_p, alpha)[:, None] * np.tensordot(hw, p, 1)
    cq = np.zeros(((lmax_q + 1) ** 2, p.shape[2]))
    cq[1:] = vmf_factors(lmax_q, alpha)[1:, None] * np.tensordot(hw, q, 1)
    return cp, cq


def evaluate_shexp(p, q, table, views, normals, alpha, f0=(1.0, 1.0, 1.0), knots=None):
    """Outgoing radiance ``(T, 3)`` of an SH-exp probe at world ``(v, n, α)``.

    Parameters
    ----------
    p, q : ``(K, (lmax_p+1)², 3)`` and ``(K, (lmax_q+1)² − 1, 3)`` coefficient sets
        (a single set may be given without the leading axis).
    table : the probe's DFG table (:mod:`shbake.shading.dfg`).
    views, normals : ``(T, 3)`` unit world directions.
    alpha : GGX width, scalar or ``(T,)``; the caller checks the probe's range.
        A scalar takes the fused path (:func:`_evaluate_blocks_one_alpha`), an
        array the per-point one; they agree to ~1e-15 relative (tested).
    f0 : Schlick reflectance per channel (1 = chrome: ``E0`` alone).
    knots : ``(K,)`` increasing ``α`` of the sets (``None`` for one set).
    """
    p = np.asarray(p, float)
    q = np.asarray(q, float)
    if p.ndim == 2:
        p, q = p[None], q[None]
    knots = np.zeros(1) if knots is None else np.asarray(knots, float).reshape(-1)
    lmax_p = lmax_of(p.shape[1])
    lmax_q = lmax_of(q.shape[1] + 1)  # q has no DC row
    v = np.ascontiguousarray(np.asarray(views, float).reshape(-1, 3))
    n = np.ascontiguousarray(np.asarray(normals, float).reshape(-1, 3))
    out = np.empty((v.shape[0], 3))
    f0 = np.broadcast_to(np.asarray(f0, float), (3,)).copy()
    table = np.asarray(table, float)
    if np.ndim(alpha) == 0:
        cp, cq = blended_coefficients(p, q, knots, float(alpha), lmax_p, lmax_q)
        n_blocks = -(-v.shape[0] // BLOCK)
        bad = np.zeros(n_blocks, dtype=np.int64)
        run_blocks(
            _evaluate_blocks_one_alpha, n_blocks, v.shape[0] * 20.0 * p.shape[1],
            v, n, float(alpha), f0, sum_weights(cp), sum_weights(cq), lmax_p, lmax_q, table,
            out, bad,
        )  # fmt: skip
        if bad.any():
            raise ParameterError(f"{int(bad.sum())} points have v = -n (no half vector)")
        return out
    al = np.broadcast_to(np.asarray(alpha, float), (v.shape[0],)).copy()
    qmm, a, b = recurrence_tables(max(lmax_p, lmax_q))
    run_blocks(
        _evaluate_blocks, -(-v.shape[0] // PIXEL_BLOCK), v.shape[0] * 20.0 * p.shape[1],
        v, n, al, f0, np.ascontiguousarray(p), np.ascontiguousarray(q), knots, lmax_p, lmax_q,
        qmm, a, b, table, out,
    )  # fmt: skip
    return out


PROBE_MATERIAL = {
    "alpha": ("GGX width α (SPEC §1), within the probe's alpha_range", None),
    "f0": ("Schlick F0, scalar or RGB in [0, 1] (1: chrome)", 1.0),
}
"""What a glossy probe's :meth:`~shbake.shading.shader.Shader.shade` takes."""
DFG_INPUT = Texture("dfg", "dfg-lut", (DFG_SIZE, DFG_SIZE, 2), "/dfg",
                    "(A0, A1) over (n·v, sqrt(α)): E = F0 A0 + (1 − F0) A1 terms")  # fmt: skip
PROBE_MATERIAL_INPUTS = (Uniform("alpha", "GGX width α", "material", ""),
                  Uniform("f0", "Schlick F0, RGB", "material", ""))  # fmt: skip
"""The material uniforms of a glossy probe shader (:data:`PROBE_MATERIAL`'s names)."""


class ProbeShader(Shader):
    """What the glossy probes share: a GGX sphere of width ``alpha`` and Schlick ``f0``,
    refused outside the probe's fitted range (:func:`shbake.format.probe.check_probe_alpha`:
    probes do not extrapolate)."""

    material = PROBE_MATERIAL
    truth = "ggx"
    min_nv = 1e-3
    """Points with ``n·v`` at or below this are not shaded (grazing: no half vector)."""

    def __init__(self, asset):
        self.asset = asset

    @classmethod
    def from_asset(cls, asset, **companions):
        from shbake.format.probe import check_probe_asset

        check_probe_asset(asset)
        return cls(asset)

    def check(self, alpha=None, f0=1.0) -> dict:
        from shbake.format.probe import check_probe_alpha

        if not np.all((0.0 <= np.asarray(f0, dtype=float)) & (np.asarray(f0, dtype=float) <= 1.0)):
            raise ParameterError(f"F0 must lie in [0, 1], got {f0}")
        return {"alpha": check_probe_alpha(self.asset, alpha), "f0": f0}


class ShexpShader(ProbeShader):
    """An ``shexp_probe``: ``E = F0 E0 + (1 − F0) E1``, ``E0 = P Q``, the tail
    ``E1 = P(ρ) Q(ρ) A1(n·v)/A0(1)`` (module docstring; :func:`evaluate_shexp`)."""

    name = "shexp"
    glsl = "shexp.glsl:shbakeShexp"
    kinds = ("shexp_probe",)
    inputs = (
        Texture("p", "sh-vector", ("K", "(lmax_p+1)**2", 3), "/p",
                "coefficients of log P at the mirror direction, one set per knot"),
        Texture("q", "sh-vector", ("K", "(lmax_q+1)**2-1", 3), "/q",
                "coefficients of log Q at the half-reflection vector, no DC row"),
        Uniform("knots", "GGX width α of each set", "/knots", "the hat functions' knots"),
        DFG_INPUT,
        *PROBE_MATERIAL_INPUTS,
    )  # fmt: skip

    def shade(self, normals, views, alpha=None, f0=1.0):
        a, m = self.asset, self.check(alpha, f0)
        return evaluate_shexp(a["/p"], a["/q"], a["/dfg"], views, normals, m["alpha"], m["f0"],
                              a["/knots"])  # fmt: skip
