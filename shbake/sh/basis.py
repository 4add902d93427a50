"""Real spherical harmonics (SPEC §2).

Real, orthonormal over the sphere, no Condon–Shortley phase, flat index
``i = l*(l+1) + m``. For a unit vector ``d = (x, y, z)`` with ``θ`` from +Z and
``φ`` from +X toward +Y::

    y_l0  = P̄_l^0(z)
    y_lm  = √2 P̄_l^m(z) cos(mφ),   m > 0
    y_l-m = √2 P̄_l^m(z) sin(mφ),   m > 0

where ``P̄_l^m = sqrt((2l+1)/(4π) (l-m)!/(l+m)!) P_l^m`` (no ``(-1)^m``).

The evaluation never forms ``P_l^m`` nor ``sin^m θ`` separately: it runs the
normalised recurrence on ``Q_l^m = P̄_l^m / sin^m θ`` (bounded growth, no
overflow to ``lmax`` ≫ 128) and multiplies by ``Re/Im (x + i y)^m =
sin^m θ cos/sin(mφ)``, which is exact at the poles and needs no ``atan2``
(the approach of sphericart, Bigi et al. 2023).

Recurrence (``Q_m^m`` a constant per ``m``, ``Q_{m-1}^m := 0``)::

    Q_m^m = sqrt((2m+1)/(2m)) Q_{m-1}^{m-1},   Q_0^0 = 1/sqrt(4π)
    Q_l^m = a_lm (z Q_{l-1}^m - b_lm Q_{l-2}^m),   l ≥ m+1
    a_lm = sqrt((4l²-1)/(l²-m²)),  b_lm = sqrt(((l-1)²-m²)/(4(l-1)²-1))

(``a_{m+1,m} = sqrt(2m+3)``, ``b_{m+1,m} = 0``: one formula for every step.)
It is written once, in :func:`legendre_next`; every evaluator here, the
projection's latitude stage and the kernels of other packages call it.

The fused :func:`evaluate` runs the same recurrence rescaled to one multiply
and one fused multiply-add per step, ``R_l^m = Q_l^m / (Q_m^m γ_l^m)``::

    R_m^m = 1,   R_l^m = z R_{l-1}^m - β_lm R_{l-2}^m      (legendre_next_scaled)
    γ_lm = a_lm γ_{l-1,m} (γ_mm = 1),   β_lm = b_lm / a_{l-1,m} (β_{m+1,m} = 0)

with ``Q_m^m γ_lm`` folded into the coefficients (:func:`scaled_recurrence_tables`;
``γ`` stays below ``4^l``, so no overflow to ``lmax`` 128).

Evaluators: :func:`real_sh` (numpy, vectorised, no compilation: small jobs
and start-up), :func:`sh_eval_into` (one direction, inside other kernels),
:func:`real_sh_into` (stored basis, blocked, into a preallocated output) and
:func:`evaluate` (``Σ_i c_i y_i(d)`` fused and blocked: the basis is never
stored).
"""

import math
from functools import cache

import numpy as np

from shbake.conventions import check_lmax, lmax_of, n_coeffs, unit_vectors
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.simd import (
    LANES,
    aligned_empty,
    inline_into_callers,
    stream_fence,
    stream_store,
    vload,
    vsplat,
    vstore,
    wide_vectors,
)

SQRT2 = np.sqrt(2.0)

BLOCK = 256
"""Directions per block of the blocked evaluators: their scratch (16 rows of ``BLOCK``
doubles, 32 KiB) stays in the L1 cache (48 KiB here); 128 and 512 measured the same."""

FUSED_CHANNELS = 3
"""Channels summed in one pass of :func:`evaluate`'s kernel (RGB)."""


@cache
def recurrence_tables(lmax: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients of the normalised recurrence (module doc), shape ``(lmax+1, lmax+1)`` each.

    Returns ``(qmm, a, b)``: ``qmm[m] = Q_m^m`` (a constant; 1-D), ``a[l, m]``
    and ``b[l, m]`` for ``l >= m + 1`` (zero elsewhere). Read-only arrays.
    """
    qmm = np.empty(lmax + 1)
    qmm[0] = 1.0 / np.sqrt(4.0 * np.pi)
    for m in range(1, lmax + 1):
        qmm[m] = qmm[m - 1] * np.sqrt((2.0 * m + 1.0) / (2.0 * m))
    a = np.zeros((lmax + 1, lmax + 1))
    b = np.zeros((lmax + 1, lmax + 1))
    for m in range(lmax + 1):
        for l in range(m + 1, lmax + 1):
            a[l, m] = np.sqrt((4.0 * l * l - 1.0) / (l * l - m * m))
            b[l, m] = np.sqrt(((l - 1.0) ** 2 - m * m) / (4.0 * (l - 1.0) ** 2 - 1.0))
    for t in (qmm, a, b):
        t.flags.writeable = False
    return qmm, a, b


@cache
def scaled_recurrence_tables(lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """``(γ, β)`` of the rescaled recurrence (module doc), shape ``(lmax+1, lmax+1)`` each.

    Derived from :func:`recurrence_tables`: ``γ[l, m] = Π_{k=m+1}^{l} a[k, m]``
    (1 at ``l = m``), ``β[l, m] = b[l, m] / a[l-1, m]`` for ``l ≥ m + 2`` (zero
    elsewhere), so that ``Q_l^m = γ[l, m] R_l^m``. Read-only arrays.
    """
    _, a, b = recurrence_tables(lmax)
    gamma = np.zeros((lmax + 1, lmax + 1))
    beta = np.zeros((lmax + 1, lmax + 1))
    for m in range(lmax + 1):
        gamma[m, m] = 1.0
        for l in range(m + 1, lmax + 1):
            gamma[l, m] = gamma[l - 1, m] * a[l, m]
            if l >= m + 2:
                beta[l, m] = b[l, m] / a[l - 1, m]
    for t in (gamma, beta):
        t.flags.writeable = False
    return gamma, beta


@jit
def legendre_next_scaled(beta_lm, z, r1, r2):
    """``R_l^m`` from ``r1 = R_{l-1}^m``, ``r2 = R_{l-2}^m``: the rescaled step (module doc)."""
    return z * r1 - beta_lm * r2


@jit
def legendre_next(alm, blm, z, q1, q2):
    """``Q_l^m(z)`` from ``q1 = Q_{l-1}^m(z)`` and ``q2 = Q_{l-2}^m(z)`` — THE recurrence.

    ``alm = a[l, m]``, ``blm = b[l, m]`` from :func:`recurrence_tables`; start
    with ``q1 = qmm[m]``, ``q2 = 0``. Scalars in kernels; ``legendre_next.py_func``
    takes numpy arrays for ``z, q1, q2`` (used by :func:`real_sh`).
    """
    return alm * (z * q1 - blm * q2)


def real_sh(dirs, lmax: int) -> np.ndarray:
    """Evaluate all real SH up to ``lmax`` at unit directions (vectorised numpy, no numba).

    The choice for small jobs (no compilation, no kernel cache to load); for
    many directions use :func:`real_sh_into` or, better, :func:`evaluate`.

    Parameters
    ----------
    dirs : array_like, shape (..., 3)
        Directions; normalised here. Finite and non-zero.
    lmax : int, 0 … 128
        Highest band.

    Returns
    -------
    ndarray, shape (..., (lmax+1)^2), float64

    Examples
    --------
    At the pole ``+Z`` only the ``m = 0`` functions are non-zero: ``y_00 = 1/sqrt(4π)``,
    ``y_10 = sqrt(3/(4π))`` (index ``l(l+1)+m``, SPEC §2):

    >>> real_sh([0.0, 0.0, 1.0], 1).round(6).tolist()
    [0.282095, 0.0, 0.488603, 0.0]
    """
    lmax = check_lmax(lmax)
    d = unit_vectors(dirs)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    qmm, a, b = recurrence_tables(lmax)
    step = legendre_next.py_func
    out = np.empty(d.shape[:-1] + (n_coeffs(lmax),))
    cm = np.ones_like(x)  # Re (x + iy)^m
    sm = np.zeros_like(x)  # Im (x + iy)^m
    for m in range(lmax + 1):
        if m > 0:
            cm, sm = cm * x - sm * y, cm * y + sm * x
        q1 = np.full_like(z, qmm[m])
        q2 = 0.0
        for l in range(m, lmax + 1):
            if l > m:
                q1, q2 = step(a[l, m], b[l, m], z, q1, q2), q1
            base = l * (l + 1)
            if m == 0:
                out[..., base] = q1
            else:
                out[..., base + m] = SQRT2 * q1 * cm
                out[..., base - m] = SQRT2 * q1 * sm
    return out


@jit
def sh_eval_into(x, y, z, lmax, qmm, a, b, out):
    """Write the ``(lmax+1)^2`` real SH of the unit vector ``(x, y, z)`` into ``out``.

    Check-free kernel: ``(x, y, z)`` must be unit length, ``out`` long enough,
    ``qmm, a, b`` from :func:`recurrence_tables` of at least ``lmax``.
    """
    cm = 1.0
    sm = 0.0
    for m in range(lmax + 1):
        if m > 0:
            cm, sm = cm * x - sm * y, cm * y + sm * x
        q1 = qmm[m]
        q2 = 0.0
        for l in range(m, lmax + 1):
            if l > m:
                q = legendre_next(a[l, m], b[l, m], z, q1, q2)
                q2 = q1
                q1 = q
            base = l * (l + 1)
            if m == 0:
                out[base] = q1
            else:
                out[base + m] = 1.4142135623730951 * q1 * cm
                out[base - m] = 1.4142135623730951 * q1 * sm


# Scratch rows of the blocked kernels. They live in ONE array (row r at
# offset r*BLOCK): LLVM then sees the distances between them and vectorises
# the block loops without runtime alias checks (separate arrays defeat it).
_X, _Y, _Z, _CM, _SM, _Q1, _Q2, _A0, _A1, _A2 = (i * BLOCK for i in range(10))
_SCRATCH = 10 * BLOCK

BASIS_PAD = 8
"""Padding of the stored-basis scratch rows: a row stride of ``BLOCK`` doubles (2 KiB) would
put a block's ``n_coeffs`` values of one direction in 2 of the L1 cache's 64 sets; the
transposing write-out then ran 1.45× slower."""


TINY2 = 1e-290
"""Squared lengths outside ``[TINY2, 1/TINY2]`` take :func:`_load_block`'s careful path."""


@jit(error_model="numpy")
def _load_block(d, i0, nb, s):
    """Normalise directions ``d[i0:i0+nb]`` into the x, y, z rows of ``s``; count the bad ones.

    Fast path (vectorised: a de-interleaving copy, then a branch-free loop;
    ``error_model="numpy"`` and ``r2**0.5`` let LLVM use packed division and
    square root): ``d / |d|``. Directions whose squared length falls outside
    ``[TINY2, 1/TINY2]`` (tiny, huge, zero or not finite: rare) are redone one
    by one, scaled by their largest component first (no underflow or overflow
    for any finite non-zero vector). A zero or non-finite direction is
    replaced by +Z and counted (the caller raises).
    """
    wide_vectors()
    f = d.reshape(d.size)
    for k in range(nb):
        j = 3 * (i0 + k)
        s[_X + k] = np.float64(f[j])
        s[_Y + k] = np.float64(f[j + 1])
        s[_Z + k] = np.float64(f[j + 2])
    odd = 0
    for k in range(nb):
        dx = s[_X + k]
        dy = s[_Y + k]
        dz = s[_Z + k]
        r2 = dx * dx + dy * dy + dz * dz
        ok = (r2 >= TINY2) & (r2 <= 1.0 / TINY2)  # False for NaN
        odd += np.int64(not ok)
        inv = 1.0 / (r2 if ok else 1.0) ** 0.5
        s[_X + k] = dx * inv
        s[_Y + k] = dy * inv
        s[_Z + k] = dz * inv
    if odd == 0:
        return 0
    bad = 0
    for k in range(nb):
        dx = np.float64(d[i0 + k, 0])
        dy = np.float64(d[i0 + k, 1])
        dz = np.float64(d[i0 + k, 2])
        r2 = dx * dx + dy * dy + dz * dz
        if r2 >= TINY2 and r2 <= 1.0 / TINY2:
            continue
        m = max(abs(dx), max(abs(dy), abs(dz)))  # scale first: no under/overflow
        if m > 0.0 and m < np.inf:
            ux = dx / m
            uy = dy / m
            uz = dz / m
            inv = 1.0 / np.sqrt(ux * ux + uy * uy + uz * uz)
            s[_X + k] = ux * inv
            s[_Y + k] = uy * inv
            s[_Z + k] = uz * inv
        else:
            bad += 1
            s[_X + k] = 0.0
            s[_Y + k] = 0.0
            s[_Z + k] = 1.0
    return bad


@jit
def _next_m(s, nb, m):
    """Advance ``Re/Im (x+iy)^m`` (rows CM, SM) to order ``m`` (``m = 0``: set them to 1, 0)."""
    wide_vectors()
    if m > 0:
        for k in range(nb):
            c_ = s[_CM + k] * s[_X + k] - s[_SM + k] * s[_Y + k]
            s[_SM + k] = s[_CM + k] * s[_Y + k] + s[_SM + k] * s[_X + k]
            s[_CM + k] = c_
    else:
        for k in range(nb):
            s[_CM + k] = 1.0
            s[_SM + k] = 0.0


@jit
def _next_l(s, nb, alm, blm, qc, qp):
    """One recurrence step for the block, in place: row ``qp`` (``Q_{l-2}``) becomes ``Q_l``.

    ``qc`` holds ``Q_{l-1}``; afterwards the caller swaps the roles of the rows
    (ping-pong: one store per direction and step).
    """
    for k in range(nb):
        s[qp + k] = legendre_next(alm, blm, s[_Z + k], s[qc + k], s[qp + k])


@jit
def _evaluate_weights(coef, lmax, qmm, gamma, beta):
    """Per-step constants of :func:`_evaluate_blocks`, ``(groups, lmax+1, lmax+1, 8)``.

    For channel group ``g`` (:data:`FUSED_CHANNELS` channels), order ``m`` and
    degree ``l ≥ m``: ``(β_lm, w+_0, w-_0, w+_1, w-_1, w+_2, w-_2, 0)`` with
    ``w± = f Q_m^m γ_lm (c_lm, c_l,-m)``, ``f = √2`` for ``m > 0`` (``(c_l0, 0)``
    and ``f = 1`` for ``m = 0``): the basis's √2, the column's first value
    ``Q_m^m`` and the rescaled recurrence's ``γ`` folded into the coefficients,
    so the kernel runs ``R_l`` from ``R_m = 1``. Zero for missing channels.
    """
    nc = coef.shape[1]
    groups = -(-nc // FUSED_CHANNELS)
    w = np.zeros((groups, lmax + 1, lmax + 1, 8))
    for g in range(groups):
        for m in range(lmax + 1):
            f = qmm[m] * (1.0 if m == 0 else 1.4142135623730951)
            for l in range(m, lmax + 1):
                i = l * (l + 1) + m
                w[g, m, l, 0] = beta[l, m]
                for c in range(min(FUSED_CHANNELS, nc - g * FUSED_CHANNELS)):
                    ch = g * FUSED_CHANNELS + c
                    w[g, m, l, 1 + 2 * c] = f * gamma[l, m] * coef[i, ch]
                    if m > 0:
                        w[g, m, l, 2 + 2 * c] = f * gamma[l, m] * coef[i - 2 * m, ch]
    return w


@jit(fastmath={"contract"})
def _sum_block(s, nv, wg, lmax):
    """Rows ``A0 … A2`` of ``s`` = the fused sums of one channel group (weights ``wg``, one
    group of :func:`_evaluate_weights`) at the ``nv`` unit directions in rows ``X, Y, Z``
    (``nv`` a multiple of ``LANES``). Check-free.

    The directions are taken :data:`~shbake.simd.LANES` at a time as explicit
    vectors (:func:`~shbake.simd.vload`) that stay in registers for the whole
    sum: per order ``m``, the rescaled recurrence ``R_l = z R_{l-1} - β_lm
    R_{l-2}`` runs down the column ``l = m … lmax`` and each ``R_l`` is added
    into the partial sums ``P±_c += w±_c R_l`` (``P-`` only for ``m > 0``),
    then ``A_c += P+_c Re(x+iy)^m + P-_c Im(x+iy)^m``. At lmax 8 that is 45
    steps of 8 flops per direction, 8 directions per AVX-512 instruction.
    """
    inline_into_callers()
    for k in range(0, nv, LANES):
        x = vload(s, _X + k)
        y = vload(s, _Y + k)
        z = vload(s, _Z + k)
        r1 = vsplat(1.0)  # m = 0: the cosine sums only
        r2 = vsplat(0.0)
        a0 = vsplat(wg[0, 0, 1])
        a1 = vsplat(wg[0, 0, 3])
        a2 = vsplat(wg[0, 0, 5])
        for l in range(1, lmax + 1):
            r = legendre_next_scaled(wg[0, l, 0], z, r1, r2)
            r2 = r1
            r1 = r
            a0 = a0 + wg[0, l, 1] * r
            a1 = a1 + wg[0, l, 3] * r
            a2 = a2 + wg[0, l, 5] * r
        cm = x  # Re, Im (x+iy)^m for m = 1
        sm = y
        for m in range(1, lmax + 1):
            wm = wg[m]
            r1 = vsplat(1.0)
            r2 = vsplat(0.0)
            p0 = vsplat(wm[m, 1])
            p1 = vsplat(wm[m, 2])
            p2 = vsplat(wm[m, 3])
            p3 = vsplat(wm[m, 4])
            p4 = vsplat(wm[m, 5])
            p5 = vsplat(wm[m, 6])
            for l in range(m + 1, lmax + 1):
                r = legendre_next_scaled(wm[l, 0], z, r1, r2)
                r2 = r1
                r1 = r
                p0 = p0 + wm[l, 1] * r
                p1 = p1 + wm[l, 2] * r
                p2 = p2 + wm[l, 3] * r
                p3 = p3 + wm[l, 4] * r
                p4 = p4 + wm[l, 5] * r
                p5 = p5 + wm[l, 6] * r
            a0 = a0 + p0 * cm + p1 * sm
            a1 = a1 + p2 * cm + p3 * sm
            a2 = a2 + p4 * cm + p5 * sm
            cm, sm = cm * x - sm * y, cm * y + sm * x
        vstore(s, _A0 + k, a0)
        vstore(s, _A1 + k, a1)
        vstore(s, _A2 + k, a2)


@jit(fastmath={"contract"})
def _evaluate_blocks(d, coef, lmax, qmm, gamma, beta, out, bad, b0, b1):
    """``out[i, c] = Σ_j coef[j, c] ȳ_j(d_i)`` for blocks ``b0 … b1-1`` (fused: no basis stored).

    ``coef`` is ``(n_coeffs, C)`` in the flat index. ``bad[blk]`` receives the
    count of unusable directions. Check-free kernel.

    Each block's directions are normalised into scratch rows
    (:func:`_load_block`) and summed :data:`FUSED_CHANNELS` channels at a time
    (:func:`_sum_block`). The sums go out through scratch rows with streaming
    stores (read by nobody until the call returns).
    """
    wide_vectors()
    n = d.shape[0]
    nc = out.shape[1]
    s = aligned_empty(_SCRATCH)
    w = _evaluate_weights(coef, lmax, qmm, gamma, beta)
    fo = out.reshape(out.size)
    for blk in range(b0, b1):
        i0 = blk * BLOCK
        nb = min(BLOCK, n - i0)
        bad[blk] = _load_block(d, i0, nb, s)
        nv = -(-nb // LANES) * LANES
        for k in range(nb, nv):  # the last vector's spare lanes: +Z
            s[_X + k] = 0.0
            s[_Y + k] = 0.0
            s[_Z + k] = 1.0
        for g in range(0, nc, FUSED_CHANNELS):
            ng = min(FUSED_CHANNELS, nc - g)
            wg = w[g // FUSED_CHANNELS]
            _sum_block(s, nv, wg, lmax)
            for k in range(nb):
                o = (i0 + k) * nc + g
                stream_store(fo, o, s[_A0 + k])
                if ng > 1:
                    stream_store(fo, o + 1, s[_A1 + k])
                if ng > 2:
                    stream_store(fo, o + 2, s[_A2 + k])
    stream_fence()


def sum_weights(coeffs) -> np.ndarray:
    """The weights :func:`add_sums` takes for ``((lmax+1)², C ≤ 3)`` coefficients (the fused
    kernel's per-step constants, :func:`_evaluate_weights`)."""
    c = np.ascontiguousarray(np.asarray(coeffs, dtype=np.float64))
    if c.ndim != 2 or c.shape[1] > FUSED_CHANNELS:
        raise ParameterError(f"expected ((lmax+1)^2, C <= 3) coefficients, got {c.shape}")
    lmax = check_lmax(lmax_of(c.shape[0]))
    gamma, beta = scaled_recurrence_tables(lmax)
    return _evaluate_weights(c, lmax, recurrence_tables(lmax)[0], gamma, beta)[0]


@jit
def sum_scratch():
    """Scratch of :func:`add_sums` (one per thread, reused for every block)."""
    return aligned_empty(_SCRATCH)


@jit(fastmath={"contract"})
def add_sums(d, nb, weights, lmax, s, acc):
    """``acc[k, c] += Σ_j coef[j, c] ȳ_j(d_k)`` for the first ``nb ≤`` :data:`BLOCK` rows of
    ``d`` — :func:`evaluate`'s fused sum for one block, inside another kernel.

    ``d``: ``(≥ nb, 3)`` C-contiguous directions (normalised here), ``weights``
    from :func:`sum_weights`, ``lmax`` theirs, ``s`` from :func:`sum_scratch`,
    ``acc``: ``(≥ nb, C)``. Returns the count of zero or non-finite directions
    (taken as +Z). Check-free.
    """
    bad = _load_block(d, 0, nb, s)
    nv = -(-nb // LANES) * LANES
    for k in range(nb, nv):  # the last vector's spare lanes: +Z
        s[_X + k] = 0.0
        s[_Y + k] = 0.0
        s[_Z + k] = 1.0
    _sum_block(s, nv, weights, lmax)
    nc = acc.shape[1]
    for k in range(nb):
        acc[k, 0] += s[_A0 + k]
        if nc > 1:
            acc[k, 1] += s[_A1 + k]
        if nc > 2:
            acc[k, 2] += s[_A2 + k]
    return bad


@jit
def _basis_blocks(d, lmax, qmm, a, b, out, bad, b0, b1):
    """``out[i, j] = y_j(d_i)`` for blocks ``b0 … b1-1`` (stored basis). Check-free kernel.

    Each block's basis is built column by column (vectorised over the block)
    in a ``(n_coeffs, BLOCK + BASIS_PAD)`` scratch, then written out row by
    row with streaming stores, so that the output is written sequentially and
    its lines are not read from memory first.
    """
    n = d.shape[0]
    nco = out.shape[1]
    s = aligned_empty(_SCRATCH)
    y = np.empty((nco, BLOCK + BASIS_PAD))
    fo = out.reshape(out.size)
    for blk in range(b0, b1):
        i0 = blk * BLOCK
        nb = min(BLOCK, n - i0)
        bad[blk] = _load_block(d, i0, nb, s)
        for m in range(lmax + 1):
            _next_m(s, nb, m)
            for k in range(nb):
                s[_Q1 + k] = qmm[m]
                s[_Q2 + k] = 0.0
            for l in range(m, lmax + 1):
                qr = _Q1
                if l > m:
                    if (l - m) % 2 == 1:
                        _next_l(s, nb, a[l, m], b[l, m], _Q1, _Q2)
                        qr = _Q2
                    else:
                        _next_l(s, nb, a[l, m], b[l, m], _Q2, _Q1)
                base = l * (l + 1)
                if m == 0:
                    for k in range(nb):
                        y[base, k] = s[qr + k]
                else:
                    for k in range(nb):
                        q = s[qr + k]
                        y[base + m, k] = 1.4142135623730951 * q * s[_CM + k]
                        y[base - m, k] = 1.4142135623730951 * q * s[_SM + k]
        o0 = i0 * nco
        for k in range(nb):
            for j in range(nco):
                stream_store(fo, o0 + k * nco + j, y[j, k])
    stream_fence()


def _flat_directions(dirs) -> tuple[np.ndarray, tuple]:
    """``(N, 3)`` float32/float64 C-contiguous view (copy only when needed) and the batch shape."""
    d = np.asarray(dirs)
    if d.dtype != np.float32 and d.dtype != np.float64:
        d = d.astype(np.float64)
    if d.shape[-1:] != (3,):
        raise ParameterError(f"directions must have a last axis of 3, got shape {d.shape}")
    return np.ascontiguousarray(d.reshape(-1, 3)), d.shape[:-1]


def _check_out(out, shape) -> np.ndarray:
    if out is None:
        return np.empty(shape)
    size = math.prod(shape)
    if (
        not isinstance(out, np.ndarray)
        or out.dtype != np.float64
        or out.size != size
        or not out.flags.c_contiguous
        or not out.flags.writeable
    ):
        raise ParameterError(f"out must be a writeable C-contiguous float64 array of {size} values")
    return out


def _raise_if_bad(bad) -> None:
    if bad.any():
        raise ParameterError(f"{int(bad.sum())} directions are zero or not finite")


def real_sh_into(dirs, lmax: int, out=None) -> np.ndarray:
    """All real SH up to ``lmax`` at ``dirs`` — the stored basis, blocked numba kernel.

    Parameters
    ----------
    dirs : array_like, (..., 3), float32 or float64
        Directions, normalised here; zero or non-finite ones raise
        :class:`~shbake.errors.ParameterError` (found by the kernel itself:
        validation costs no extra pass over the input).
    lmax : int, 0 … 128
    out : ndarray, optional
        Preallocated C-contiguous float64 output with ``N × (lmax+1)^2``
        values (any shape of that size); written in place and returned.

    Returns
    -------
    ndarray, (..., (lmax+1)^2), float64 (``out`` if given, in its shape)
    """
    lmax = check_lmax(lmax)
    d, batch = _flat_directions(dirs)
    nco = n_coeffs(lmax)
    res = _check_out(out, (d.shape[0], nco))
    n_blocks = -(-d.shape[0] // BLOCK)
    bad = np.zeros(n_blocks, dtype=np.int64)
    qmm, a, b = recurrence_tables(lmax)
    run_blocks(
        _basis_blocks,
        n_blocks,
        d.shape[0] * nco * 4,
        d,
        lmax,
        qmm,
        a,
        b,
        res.reshape(d.shape[0], nco),
        bad,
    )
    _raise_if_bad(bad)
    return res if out is not None else res.reshape(batch + (nco,))


def real_sh_numba(dirs, lmax: int) -> np.ndarray:
    """Same as :func:`real_sh`, by the blocked kernel of :func:`real_sh_into`."""
    return real_sh_into(dirs, lmax)


SMALL_EVALUATION = 1 << 20
"""``method="auto"`` evaluates ``N × n_coeffs`` up to this with numpy (nothing compiled or
loaded: loading numba costs ~0.35 s), larger jobs with numba; the choice depends on the
input alone, so the same input gives the same bytes in any process."""


def evaluate(coeffs, dirs, out=None, method: str = "auto") -> np.ndarray:
    """Reconstruct ``f(d) = Σ_i c_i y_i(d)`` at ``dirs`` without storing the basis.

    Fused and blocked (:data:`BLOCK` directions at a time, their recurrence and
    the sum over coefficients in L1-resident scratch, vectorised across the
    block), run by :func:`shbake.jit.run_blocks`.

    Parameters
    ----------
    coeffs : array_like, ((lmax+1)^2,) or ((lmax+1)^2, C)
        SH coefficients in the flat index ``l(l+1)+m``.
    dirs : array_like, (..., 3), float32 or float64
        Directions, normalised here (zero / non-finite ones raise).
    out : ndarray, optional
        Preallocated C-contiguous float64 array with ``N`` (or ``N × C``) values.
    method : ``"auto"``, ``"numba"`` or ``"numpy"``
        ``numba``: the fused kernel. ``numpy``: ``real_sh(dirs) @ coeffs``
        (stores the basis; nothing compiled or loaded). ``auto``: ``numpy``
        for jobs up to :data:`SMALL_EVALUATION` basis values, else ``numba``.
        The two agree to ~1e-15 relative, not bit for bit.

    Returns
    -------
    ndarray, ``dirs.shape[:-1]`` or ``dirs.shape[:-1] + (C,)``, float64
    """
    if method not in ("auto", "numba", "numpy"):
        raise ParameterError(f"unknown method {method!r}; choose auto, numba or numpy")
    c = np.asarray(coeffs, dtype=np.float64)
    if c.ndim not in (1, 2):
        raise ParameterError(f"coeffs must be 1-D or 2-D, got shape {c.shape}")
    lmax = check_lmax(lmax_of(c.shape[0]))
    d, batch = _flat_directions(dirs)
    if method == "auto":
        small = d.shape[0] * c.shape[0] <= SMALL_EVALUATION
        method = "numpy" if small else "numba"
    if method == "numpy":
        res = real_sh(d, lmax) @ c
        if out is not None:
            _check_out(out, res.shape)[...] = res.reshape(out.shape)
            return out
        return res.reshape(batch + c.shape[1:])
    c2 = np.ascontiguousarray(c.reshape(c.shape[0], -1))
    nc = c2.shape[1]
    res = _check_out(out, (d.shape[0], nc))
    n_blocks = -(-d.shape[0] // BLOCK)
    bad = np.zeros(n_blocks, dtype=np.int64)
    qmm = recurrence_tables(lmax)[0]
    gamma, beta = scaled_recurrence_tables(lmax)
    run_blocks(
        _evaluate_blocks,
        n_blocks,
        d.shape[0] * c.shape[0] * (nc + 2),
        d,
        c2,
        lmax,
        qmm,
        gamma,
        beta,
        res.reshape(d.shape[0], nc),
        bad,
    )
    _raise_if_bad(bad)
    if out is not None:
        return out
    return res.reshape(batch + c.shape[1:])
