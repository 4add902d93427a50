"""Projection of radiance on the sphere onto real SH: ``L_lm = ∫ L(ω) y_lm(ω) dω``.

Two quadratures:

* :func:`project_latlong` — the separable path of Ramamoorthi & Hanrahan 2002
  §6.1 for lat-long images. In the *image frame* (pole = the image's +Y,
  azimuth ``φ' = -2πu``, proper rotation of the world frame) every SH is
  ``P̄_l^m(cos θ') × cos/sin(mφ')`` and the pixel grid is a product grid, so
  (1) each row is summed against ``cos/sin(mφ'_j)`` — a small matrix product
  against one table shared by every row (or a real FFT when ``lmax`` is
  large) — and (2) the row sums are combined with ``P̄_l^m(cos θ'_i)`` times
  the row's quadrature weight. Cost ``O(lmax × pixels)``. The image-frame
  coefficients are rotated into the world frame at the end.

  Row centres ``θ_i = π(i+½)/H`` are the nodes of Fejér's first rule, so the
  weights are Fejér's (Waldvogel 2006): the projection is *exact* for any
  map whose content is band-limited below ``l = H`` (a constant map gives
  ``L_00 = sqrt(4π)`` and zeros, to rounding). The weights differ from the
  exact cell solid angles of SPEC §3 by O(pixel²) and sum to the same 4π;
  the midpoint rule with cell areas would leave e.g. −2.5e-5 in ``L_20`` of a
  constant 512×256 map.
* :func:`project_samples` — any set of directions with weights (cube maps:
  exact texel solid angles).
"""

from functools import lru_cache

import numpy as np

from shbake.conventions import band_of_index, check_lmax, n_coeffs
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.basis import legendre_next, real_sh, real_sh_numba, recurrence_tables
from shbake.sh.rotation import SHRotation
from shbake.simd import (
    LANES,
    aligned_empty,
    inline_into_callers,
    prefetch,
    vload,
    vload_channels,
    vsplat,
    vstore,
    vsum,
    wide_vectors,
)

IMAGE_FRAME = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""Rotation taking world directions to the lat-long image frame: ``d' = IMAGE_FRAME @ d``,
``x' = -d_z, y' = -d_x, z' = d_y`` (det +1)."""

FFT_MIN_LMAX = 64
"""From this ``lmax`` on, row sums use a real FFT instead of the cos/sin table."""

ROWS_PER_BLOCK = 4
"""Rows per work item handed to a thread by :func:`shbake.jit.run_blocks`."""


@lru_cache(maxsize=16)
def fejer_row_weights(height: int, width: int) -> np.ndarray:
    """Fejér first-rule weight of one pixel of each row, ``(2π/W) w_i``, shape ``(height,)``.

    ``w_i = (2/H) (1 - 2 Σ_{k=1}^{⌊H/2⌋} cos(2kθ_i)/(4k²-1))``, ``θ_i = π(i+½)/H``;
    ``Σ_i w_i = 2``. Read-only.

    The sum is a DCT-III of ``a_0 = 1``, ``a_2k = -2/(4k²-1)`` (the term
    ``2k = H`` vanishes at every node), evaluated by one complex FFT of length
    ``2H``: ``O(H log H)`` instead of ``H²/2`` cosines.
    """
    h = height
    a = np.zeros(h)
    a[0] = 1.0
    k = np.arange(1, (h - 1) // 2 + 1)
    a[2 * k] = -2.0 / (4.0 * k * k - 1.0)
    b = np.zeros(2 * h, dtype=np.complex128)
    b[:h] = a * np.exp(0.5j * np.pi * np.arange(h) / h)
    dct = (2 * h) * np.fft.ifft(b)[:h].real  # Σ_j a_j cos(π j (i+½)/H)
    w = (2.0 / h) * dct * (2.0 * np.pi / width)
    w.flags.writeable = False
    return w


@lru_cache(maxsize=16)
def azimuth_tables(width: int, lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """``cos(mφ'_j)``, ``sin(mφ'_j)`` as ``(lmax+1, n)`` rows; ``φ'_j = -2π(j+½)/W``.

    ``n = W/4`` when ``W % 4 == 0`` (the quarter-fold kernel), else ``⌈W/2⌉``,
    each row zero-padded to a multiple of :data:`~shbake.simd.LANES` and the
    arrays 64-byte aligned (whole vector loads). Column ``W-1-j`` has ``φ' =
    -φ'_j`` (same cos, opposite sin); for ``W % 4 == 0`` column ``W/2-1-j``
    has ``φ' = -π-φ'_j`` (cos × ``(-1)^m``, sin × ``-(-1)^m``). Read-only.
    """
    n = width // 4 if width % 4 == 0 else (width + 1) // 2
    padded = -(-n // LANES) * LANES
    phi = -2.0 * np.pi * (np.arange(n) + 0.5) / width
    m = np.arange(lmax + 1)
    tables = []
    for f in (np.cos, np.sin):
        t = aligned_empty((lmax + 1) * padded).reshape(lmax + 1, padded)
        t[:, n:] = 0.0
        t[:, :n] = f(np.outer(m, phi))
        t.flags.writeable = False
        tables.append(t)
    return tables[0], tables[1]


COLUMN_BLOCK = 64 if LANES == 16 else 128
"""Folded columns per pass of the row kernels (a multiple of LANES), measured on each vector
width. The folded values of a block (4 × channels × COLUMN_BLOCK doubles) and its table
columns (2 (lmax+1) × COLUMN_BLOCK doubles) are reused by every ``m``; longer blocks add
fewer per-block partial sums. 4096×2048 RGB lmax 8: with AVX-512 (16 lanes, Intel Xeon,
L1 prefetch) 11.3 ms with 64 columns, 12.2 with 128, 14 with 256; with AVX2 (4 lanes, AMD
EPYC, L2 prefetch, alternating processes) 13.8–15.7 ms with 64, 13.0–13.5 with 128
(lmax 30: 33.3–36.2 → 31.8–32.6)."""

_FAST = {"reassoc", "contract"}

_U = np.uint64


@jit
def _prefetch_until(flat, p, stop, line):
    """Request the cache lines from ``flat[p]`` up to ``flat[stop]``, ``line`` elements each;
    returns the next ``p``."""
    inline_into_callers()
    while p < stop:
        prefetch(flat, p)
        p += line
    return p


@jit(fastmath=_FAST)
def _accumulate(accv, row, v):
    """``accv[row] += v`` for a ``LANES``-wide row of partial sums."""
    inline_into_callers()
    vstore(accv, row * LANES, vload(accv, row * LANES) + v)


@jit(fastmath=_FAST)
def _butterfly4(a, b, c, d, buf, ch, j):
    """Fold the values of columns ``j, W-1-j, W/2-1-j, W/2+j`` (see :func:`_row_sums_quarter`);
    returns their sum ``E``."""
    inline_into_callers()
    sab = a + b
    scd = c + d
    dab = a - b
    dcd = c - d
    e = sab + scd
    buf[0, ch, j] = e
    buf[1, ch, j] = sab - scd
    buf[2, ch, j] = dab - dcd
    buf[3, ch, j] = dab + dcd
    return e


@jit(fastmath=_FAST)
def _butterfly4_vectors(a, b, c, d, buf, ch, j):
    """:func:`_butterfly4` on ``LANES`` columns ``j …`` at once (vectors ``a, b, c, d``);
    returns ``E``."""
    inline_into_callers()
    nc = buf.shape[1]
    cb = COLUMN_BLOCK
    sab = a + b
    scd = c + d
    dab = a - b
    dcd = c - d
    e = sab + scd
    vstore(buf, ch * cb + j, e)
    vstore(buf, (nc + ch) * cb + j, sab - scd)
    vstore(buf, (2 * nc + ch) * cb + j, dab - dcd)
    vstore(buf, (3 * nc + ch) * cb + j, dab + dcd)
    return e


@jit
def _coeff_index(m, sine):
    """Row-sum column of ``cos(mφ')`` (``2m-1``; 0 for m = 0) or ``sin(mφ')`` (``2m``)."""
    inline_into_callers()
    if sine:
        return 2 * m
    return 0 if m == 0 else 2 * m - 1


@jit(fastmath=_FAST)
def _dots(buf, kind, nv, j0, table, m, nm, accv, sine):
    """``accv[c, k(m')] += Σ_j buf[kind, c, j] table[m', j0+j]`` for ``m' = m, m+2, … < nm``.

    Over ``nv`` vectors of ``LANES`` columns, as ``LANES``-lane partial sums
    (``accv`` is ``(C, 2 nm-1, LANES)`` flat). A ``(C × nj) · (nj ×
    ⌈(nm-m)/2⌉)`` product in register tiles of 3 channels × 4 ``m`` for RGB
    (7 vector loads per 12 multiply-adds), 1 channel × 4 ``m`` otherwise, then
    single ``m``. Check-free kernel.
    """
    inline_into_callers()
    nc = buf.shape[1]
    cb = COLUMN_BLOCK
    stride = table.shape[1]
    nk = 2 * nm - 1
    x = kind * nc * cb
    if nc == 3:
        while m + 6 < nm:
            a00 = a01 = a02 = a10 = a11 = a12 = a20 = a21 = a22 = a30 = a31 = a32 = vsplat(0.0)
            for v in range(nv):
                jj = v * LANES
                x0 = vload(buf, x + jj)
                x1 = vload(buf, x + cb + jj)
                x2 = vload(buf, x + 2 * cb + jj)
                t = m * stride + j0 + jj
                u0 = vload(table, t)
                u1 = vload(table, t + 2 * stride)
                u2 = vload(table, t + 4 * stride)
                u3 = vload(table, t + 6 * stride)
                a00 = a00 + x0 * u0
                a01 = a01 + x1 * u0
                a02 = a02 + x2 * u0
                a10 = a10 + x0 * u1
                a11 = a11 + x1 * u1
                a12 = a12 + x2 * u1
                a20 = a20 + x0 * u2
                a21 = a21 + x1 * u2
                a22 = a22 + x2 * u2
                a30 = a30 + x0 * u3
                a31 = a31 + x1 * u3
                a32 = a32 + x2 * u3
            k0 = _coeff_index(m, sine)
            k1 = _coeff_index(m + 2, sine)
            k2 = _coeff_index(m + 4, sine)
            k3 = _coeff_index(m + 6, sine)
            _accumulate(accv, k0, a00)
            _accumulate(accv, nk + k0, a01)
            _accumulate(accv, 2 * nk + k0, a02)
            _accumulate(accv, k1, a10)
            _accumulate(accv, nk + k1, a11)
            _accumulate(accv, 2 * nk + k1, a12)
            _accumulate(accv, k2, a20)
            _accumulate(accv, nk + k2, a21)
            _accumulate(accv, 2 * nk + k2, a22)
            _accumulate(accv, k3, a30)
            _accumulate(accv, nk + k3, a31)
            _accumulate(accv, 2 * nk + k3, a32)
            m += 8
        while m < nm:
            a0 = a1 = a2 = vsplat(0.0)
            for v in range(nv):
                jj = v * LANES
                u = vload(table, m * stride + j0 + jj)
                a0 = a0 + vload(buf, x + jj) * u
                a1 = a1 + vload(buf, x + cb + jj) * u
                a2 = a2 + vload(buf, x + 2 * cb + jj) * u
            k0 = _coeff_index(m, sine)
            _accumulate(accv, k0, a0)
            _accumulate(accv, nk + k0, a1)
            _accumulate(accv, 2 * nk + k0, a2)
            m += 2
        return
    for c in range(nc):
        xc = x + c * cb
        mm = m
        while mm + 6 < nm:
            a0 = a1 = a2 = a3 = vsplat(0.0)
            for v in range(nv):
                jj = v * LANES
                xv = vload(buf, xc + jj)
                t = mm * stride + j0 + jj
                a0 = a0 + xv * vload(table, t)
                a1 = a1 + xv * vload(table, t + 2 * stride)
                a2 = a2 + xv * vload(table, t + 4 * stride)
                a3 = a3 + xv * vload(table, t + 6 * stride)
            _accumulate(accv, c * nk + _coeff_index(mm, sine), a0)
            _accumulate(accv, c * nk + _coeff_index(mm + 2, sine), a1)
            _accumulate(accv, c * nk + _coeff_index(mm + 4, sine), a2)
            _accumulate(accv, c * nk + _coeff_index(mm + 6, sine), a3)
            mm += 8
        while mm < nm:
            a0 = vsplat(0.0)
            for v in range(nv):
                jj = v * LANES
                a0 = a0 + vload(buf, xc + jj) * vload(table, mm * stride + j0 + jj)
            _accumulate(accv, c * nk + _coeff_index(mm, sine), a0)
            mm += 2


@jit
def _row_scratch(kinds, nc, nm):
    """Aligned scratch of the row kernels: folded block ``(kinds, C, COLUMN_BLOCK)``, partial
    sums ``(C × (2 nm-1) × LANES)``."""
    buf = aligned_empty(kinds * nc * COLUMN_BLOCK).reshape((kinds, nc, COLUMN_BLOCK))
    accv = aligned_empty(nc * (2 * nm - 1) * LANES)
    return buf, accv


@jit
def _finish_row(accv, out, i):
    """``out[c, k, i]`` = the lane sum of ``accv[c, k]``; ``accv`` is reset."""
    nc = out.shape[0]
    nk = out.shape[1]
    zero = vsplat(0.0)
    for c in range(nc):
        for k in range(nk):
            r = (c * nk + k) * LANES
            out[c, k, i] = vsum(vload(accv, r))
            vstore(accv, r, zero)


@jit(fastmath=_FAST)
def _row_sums_quarter(img, cos_t, sin_t, out, b0, b1):
    """Row sums against ``cos/sin(mφ')`` for ``W % 4 == 0``, rows of blocks ``b0 … b1-1``.

    ``out[c, 0, i] = Σ_j img[i, j, c]``, ``out[c, 2m-1, i] = Σ_j img cos(mφ'_j)``,
    ``out[c, 2m, i] = Σ_j img sin(mφ'_j)``. The four columns ``j, W-1-j,
    W/2-1-j, W/2+j`` share ``|cos|, |sin|`` (table doc), so each row is read
    once, folded into four ``W/4``-long vectors per channel — even / odd ``m``
    for cos / sin — a block of :data:`COLUMN_BLOCK` columns at a time, and
    every ``m`` is a dot product with one table row over that block (a
    cache-blocked ``(C × W/4) · (W/4 × 2 lmax+1)`` product, :func:`_dots`).
    For RGB, ``m = 0`` (``cos 0 = 1``: the plain sum of ``E``) is added up as
    the fold makes ``E``, so at lmax 8 every ``E`` dot is a full 4-``m`` tile
    (no latency-bound single ``m``: 13.2 → 12.6 ms at 4096×2048).

    The fold reads four runs per block: columns ``j`` and ``W/2+j`` forwards,
    ``W-1-j`` and ``W/2-1-j`` backwards. RGB is folded ``LANES`` columns at a
    time on explicit vectors (:func:`~shbake.simd.vload_channels`: one load of
    the interleaved pixels, channels split and, for the backward runs,
    reversed in registers, widened to float64); other channel counts and the
    last columns of a block one value at a time (unsigned indices: no
    negative-index wrap). No copy of the image. Check-free kernel.
    """
    wide_vectors()
    h, w, nc = img.shape
    nq = w // 4
    half = w // 2
    nm = cos_t.shape[0]
    nk = 2 * nm - 1
    buf, accv = _row_scratch(4, nc, nm)
    flat = img.reshape(h * w * nc)
    line = 64 // flat.itemsize  # elements per cache line
    end = h * w * nc
    accv[:] = 0.0
    for i in range(b0 * ROWS_PER_BLOCK, min(h, b1 * ROWS_PER_BLOCK)):
        f = img[i].reshape(w * nc)
        # The next row is prefetched as this one is folded, in address order: each fold
        # step requests as many of its values as it reads of this row (4 C per column).
        nxt = (i + 1) * w * nc
        p = nxt
        for j0 in range(0, nq, COLUMN_BLOCK):
            nj = min(COLUMN_BLOCK, nq - j0)
            nv = -(-nj // LANES)
            done = 0
            if nc == 3:
                # m = 0 (cos 0 = 1) is the sum of E: added up here, as the fold makes it
                e0 = e1 = e2 = vsplat(0.0)
                done = nj // LANES * LANES
                for j in range(0, done, LANES):
                    col = j0 + j
                    p = _prefetch_until(flat, p, min(nxt + 4 * nc * (col + LANES), end), line)
                    a0, a1, a2 = vload_channels(f, 3 * col, 3, False)
                    d0, d1, d2 = vload_channels(f, 3 * (half + col), 3, False)
                    b0_, b1_, b2_ = vload_channels(f, 3 * (w - col - LANES), 3, True)
                    c0, c1, c2 = vload_channels(f, 3 * (half - col - LANES), 3, True)
                    e0 = e0 + _butterfly4_vectors(a0, b0_, c0, d0, buf, 0, j)
                    e1 = e1 + _butterfly4_vectors(a1, b1_, c1, d1, buf, 1, j)
                    e2 = e2 + _butterfly4_vectors(a2, b2_, c2, d2, buf, 2, j)
                _accumulate(accv, 0, e0)
                _accumulate(accv, nk, e1)
                _accumulate(accv, 2 * nk, e2)
            fa = f[nc * j0 :]  # column j0 + j
            fd = f[nc * (half + j0) :]  # column W/2 + j0 + j
            rb = _U(nc * (w - 1 - j0))  # column W-1-j0-j starts at rb - C j
            rc = _U(nc * (half - 1 - j0))  # column W/2-1-j0-j starts at rc - C j
            for j in range(done, nj):
                k = nc * j
                b = rb - _U(k)
                c = rc - _U(k)
                for ch in range(nc):
                    e = _butterfly4(
                        np.float64(fa[k + ch]),
                        np.float64(f[b + _U(ch)]),
                        np.float64(f[c + _U(ch)]),
                        np.float64(fd[k + ch]),
                        buf,
                        ch,
                        j,
                    )
                    if nc == 3:  # lane 0 of the m = 0 sums (the generic path's dots do m = 0)
                        accv[ch * nk * LANES] += e
            if nj < nv * LANES:  # a partial last vector: its tail columns count zero
                buf[:, :, nj : nv * LANES] = 0.0
            p = _prefetch_until(flat, p, min(nxt + 4 * nc * (j0 + nj), end), line)
            _dots(buf, 0, nv, j0, cos_t, 2 if nc == 3 else 0, nm, accv, False)  # E · cos
            _dots(buf, 1, nv, j0, cos_t, 1, nm, accv, False)  # O · cos
            _dots(buf, 2, nv, j0, sin_t, 2, nm, accv, True)  # DO · sin
            _dots(buf, 3, nv, j0, sin_t, 1, nm, accv, True)  # DE · sin
        _finish_row(accv, out, i)


@jit(fastmath=_FAST)
def _row_sums_half(img, cos_t, sin_t, out, b0, b1):
    """As :func:`_row_sums_quarter` for any width: columns ``j`` and ``W-1-j`` folded (sum,
    difference; the middle column of an odd width is its own pair), one value at a time,
    the next row prefetched as it goes. Check-free kernel."""
    h, w, nc = img.shape
    nh = (w + 1) // 2
    pairs = w // 2
    nm = cos_t.shape[0]
    buf, accv = _row_scratch(2, nc, nm)  # sum, difference
    flat = img.reshape(h * w * nc)
    line = 64 // flat.itemsize  # elements per cache line
    end = h * w * nc
    accv[:] = 0.0
    for i in range(b0 * ROWS_PER_BLOCK, min(h, b1 * ROWS_PER_BLOCK)):
        f = img[i].reshape(w * nc)
        nxt = (i + 1) * w * nc  # the next row, prefetched as the fold reads this one
        p = nxt
        for j0 in range(0, nh, COLUMN_BLOCK):
            nj = min(COLUMN_BLOCK, nh - j0)
            nv = -(-nj // LANES)
            npair = min(nj, pairs - j0)
            fa = f[nc * j0 :]
            rb = _U(nc * (w - 1 - j0))
            for j in range(npair):
                k = nc * j
                b = rb - _U(k)
                for c in range(nc):
                    va = np.float64(fa[k + c])
                    vb = np.float64(f[b + _U(c)])
                    buf[0, c, j] = va + vb
                    buf[1, c, j] = va - vb
            if npair < nj:  # odd width: the middle column, φ' = -π
                for c in range(nc):
                    buf[0, c, npair] = np.float64(f[nc * pairs + c])
                    buf[1, c, npair] = 0.0
            if nj < nv * LANES:  # a partial last vector: its tail columns count zero
                buf[:, :, nj : nv * LANES] = 0.0
            p = _prefetch_until(flat, p, min(nxt + 2 * nc * (j0 + nj), end), line)
            _dots(buf, 0, nv, j0, cos_t, 0, nm, accv, False)
            _dots(buf, 0, nv, j0, cos_t, 1, nm, accv, False)
            _dots(buf, 1, nv, j0, sin_t, 1, nm, accv, True)
            _dots(buf, 1, nv, j0, sin_t, 2, nm, accv, True)
        _finish_row(accv, out, i)


def _row_sums_fft(img, lmax):
    import scipy.fft  # only this path needs it (lmax >= FFT_MIN_LMAX)

    h, w, nc = img.shape
    f = scipy.fft.rfft(np.asarray(img, dtype=np.float64), axis=1, workers=-1)[:, : lmax + 1, :]
    shift = np.exp(-1j * np.pi * np.arange(lmax + 1) / w)
    f = f * shift[None, :, None]
    out = np.empty((h, nc, 2 * lmax + 1))
    out[:, :, 0] = f[:, 0, :].real
    out[:, :, 1::2] = f[:, 1:, :].real.transpose(0, 2, 1)
    out[:, :, 2::2] = f[:, 1:, :].imag.transpose(0, 2, 1)
    return out


@lru_cache(maxsize=8)
def _full_table(width: int, lmax: int) -> np.ndarray:
    """``(W, 2 lmax+1)``: columns ``1, cos φ', sin φ', cos 2φ', …`` over the whole row."""
    phi = -2.0 * np.pi * (np.arange(width) + 0.5) / width
    t = np.empty((width, 2 * lmax + 1))
    t[:, 0] = 1.0
    for m in range(1, lmax + 1):
        t[:, 2 * m - 1] = np.cos(m * phi)
        t[:, 2 * m] = np.sin(m * phi)
    t.flags.writeable = False
    return t


def _row_sums_blas(img, lmax):
    """:func:`row_sums` by BLAS (no numba): rows converted to float64 channel-major in ~4 MB
    chunks — one strided cast, ``(R, W, C) → (R, C, W)`` — and one matrix product per chunk,
    ``(2 lmax+1 × W) · (W × R C)``: the table's transpose against the chunk's (BLAS reads
    both as stored), then the small result transposed into place. That orientation took
    8.1 ms where ``(R C × W) · (W × 2 lmax+1)`` took 10.2 (2048×1024 RGB lmax 8, AMD EPYC).

    One product per chunk, not per row: OpenBLAS's kernels for a 3-row product are slow
    on some CPUs (AMD EPYC, 2048×1024 RGB lmax 8: 28.7 ms per-row against 9 per chunk;
    equal on the Intel Xeon). A product of more than ~262 000 multiply-adds runs on
    OpenBLAS's thread pool if it has one, whose busy-waiting made these sums 46 ms
    instead of 9 on a loaded 2-core machine (SPEC §6): the ``shbake`` command gives
    OpenBLAS one thread (``cli/__init__.py``), and library callers choose with
    ``OPENBLAS_NUM_THREADS``."""
    h, w, nc = img.shape
    k = 2 * lmax + 1
    table_t = _full_table(w, lmax).T
    out = np.empty((h, nc, k))
    rows = max(1, (4 << 20) // (w * nc * 8))
    buf = np.empty((min(rows, h), nc, w))
    sums = np.empty((k, min(rows, h) * nc))
    for r0 in range(0, h, rows):
        r1 = min(h, r0 + rows)
        chunk = buf[: r1 - r0]
        np.copyto(chunk, img[r0:r1].transpose(0, 2, 1))
        part = sums[:, : (r1 - r0) * nc]
        np.matmul(table_t, chunk.reshape(-1, w).T, out=part)
        out[r0:r1].reshape(-1, k)[...] = part.T
    return out


def row_sums(img, lmax: int, method: str = "numba") -> np.ndarray:
    """Longitude stage: ``(H, C, 2 lmax+1)`` sums of each row against ``1, cos(mφ'), sin(mφ')``.

    ``img`` is ``(H, W, C)`` float32/float64 (read in place when C-contiguous).
    Table kernels below :data:`FFT_MIN_LMAX` (or when ``2 lmax ≥ W``), a real
    FFT above. ``method="numba"``: the folded kernels, threads by
    :func:`shbake.jit.run_blocks` (SPEC §6), returning a view of a
    ``(C, 2 lmax+1, H)`` array; ``"blas"``: :func:`_row_sums_blas`.
    """
    h, w, nc = img.shape
    if lmax >= FFT_MIN_LMAX and 2 * lmax < w:
        return _row_sums_fft(img, lmax)
    if method == "blas":
        return _row_sums_blas(img, lmax)
    img = np.ascontiguousarray(img)
    cos_t, sin_t = azimuth_tables(w, lmax)
    out = np.empty((nc, 2 * lmax + 1, h))  # the latitude stage reads rows contiguously
    kernel = _row_sums_quarter if w % 4 == 0 else _row_sums_half
    n_blocks = -(-h // ROWS_PER_BLOCK)
    work = h * w * nc * (lmax + 2)
    run_blocks(kernel, n_blocks, work, img, cos_t, sin_t, out)
    return out.transpose(2, 0, 1)


@jit(fastmath=_FAST)
def _legendre_sums(sums, z, scale0, sin_t, lmax, qmm, a, b, out):
    """Latitude stage: ``out[l(l+1)±m, c] = Σ_i P̄_l^m(z_i) w_i √2^[m>0] S_i[c, cos|sin m]``.

    ``sums`` holds the row sums ``S`` as ``(C, 2 lmax+1, H)``. Rows are paired
    with their mirror ``H-1-i`` (``z → -z``, ``P̄_l^m → (-1)^{l-m} P̄_l^m``):
    for each ``m`` the pair sums and differences of the ``cos mφ'`` and
    ``sin mφ'`` columns are formed once over the ``⌈H/2⌉`` upper rows (the
    equator row of an odd ``H`` is its own mirror), then every ``l`` is one pass
    over those rows that advances ``Q_l^m`` by
    :func:`~shbake.sh.basis.legendre_next` and accumulates the ``2C`` sums
    (summed in vector lanes: ``fastmath`` reassociation). ``z = cos θ_i``,
    ``scale0`` = row weights, ``sin_t = sin θ_i`` for the upper rows.
    Check-free kernel.
    """
    nc = sums.shape[0]
    h = sums.shape[2]
    n = z.shape[0]
    q1 = np.empty(n)
    q2 = np.empty(n)
    scale = np.empty(n)
    pc = np.empty((nc, n))  # cos column: S_i + S_{H-1-i}
    mc = np.empty((nc, n))  # cos column: S_i - S_{H-1-i}
    ps = np.zeros((nc, n))  # sin column (m > 0)
    ms = np.zeros((nc, n))
    for i in range(n):
        scale[i] = scale0[i]
    for m in range(lmax + 1):
        kc = 0 if m == 0 else 2 * m - 1
        f = 1.0 if m == 0 else 1.4142135623730951
        for c in range(nc):
            col = sums[c, kc]
            rev = col[::-1]
            for i in range(n):
                pc[c, i] = col[i] + rev[i]
                mc[c, i] = col[i] - rev[i]
            if m > 0:
                col = sums[c, 2 * m]
                rev = col[::-1]
                for i in range(n):
                    ps[c, i] = col[i] + rev[i]
                    ms[c, i] = col[i] - rev[i]
            if h % 2 == 1:  # the equator row pairs with itself
                pc[c, n - 1] = mc[c, n - 1] = sums[c, kc, n - 1]
                if m > 0:
                    ps[c, n - 1] = ms[c, n - 1] = sums[c, 2 * m, n - 1]
        for i in range(n):
            if m > 0:
                scale[i] *= sin_t[i]
            q1[i] = qmm[m] * scale[i]  # Q_m^m w_i sin^m θ_i: the recurrence is linear
            q2[i] = 0.0
        for l in range(m, lmax + 1):
            even = (l - m) % 2 == 0
            xc = pc if even else mc
            xs = ps if even else ms
            alm = a[l, m]
            blm = b[l, m]
            base = l * (l + 1)
            if nc == 3:
                c0 = c1 = c2 = s0 = s1 = s2 = 0.0
                for i in range(n):
                    if l > m:
                        q = legendre_next(alm, blm, z[i], q1[i], q2[i])
                        q2[i] = q1[i]
                        q1[i] = q
                    else:
                        q = q1[i]
                    c0 += q * xc[0, i]
                    c1 += q * xc[1, i]
                    c2 += q * xc[2, i]
                    s0 += q * xs[0, i]
                    s1 += q * xs[1, i]
                    s2 += q * xs[2, i]
                out[base + m, 0] = f * c0
                out[base + m, 1] = f * c1
                out[base + m, 2] = f * c2
                if m > 0:
                    out[base - m, 0] = f * s0
                    out[base - m, 1] = f * s1
                    out[base - m, 2] = f * s2
            else:
                if l > m:
                    for i in range(n):
                        q = legendre_next(alm, blm, z[i], q1[i], q2[i])
                        q2[i] = q1[i]
                        q1[i] = q
                for c in range(nc):
                    cs = 0.0
                    ss = 0.0
                    for i in range(n):
                        cs += q1[i] * xc[c, i]
                        ss += q1[i] * xs[c, i]
                    out[base + m, c] = f * cs
                    if m > 0:
                        out[base - m, c] = f * ss


def _legendre_sums_numpy(plus, minus, z, scale0, sin_t, lmax, qmm, a, b, out):
    """:func:`_legendre_sums` with numpy (no numba): the mirror pair sums given as ``plus``
    and ``minus``, ``(C, 2 lmax+1, ⌈H/2⌉)``; the recurrence vectorised over rows."""
    step = legendre_next.py_func
    scale = np.array(scale0, dtype=np.float64)
    for m in range(lmax + 1):
        kc = 0 if m == 0 else 2 * m - 1
        if m > 0:
            scale = scale * sin_t
        f = 1.0 if m == 0 else SQRT2
        q1 = np.full_like(z, qmm[m])
        q2 = 0.0
        for l in range(m, lmax + 1):
            if l > m:
                q1, q2 = step(a[l, m], b[l, m], z, q1, q2), q1
            qs = q1 * scale * f
            src = plus if (l - m) % 2 == 0 else minus
            base = l * (l + 1)
            out[base + m] = src[:, kc, :] @ qs
            if m > 0:
                out[base - m] = src[:, 2 * m, :] @ qs


SQRT2 = 1.4142135623730951

BLAS_MAX_LMAX = 8
"""``method="auto"`` uses numpy/BLAS up to this ``lmax`` ..."""
BLAS_MAX_PIXELS = 1 << 21
"""... for images of at most this many pixels (2048×1024): loading numba and its kernel
cache costs ~0.35 s, more than such a projection; above it the numba kernels win (4096×2048
at lmax 8: 65 ms against 145 ms). The choice depends on the input alone, so the same
input gives the same bytes in any process."""

METHODS = ("auto", "numba", "blas")


def _choose_method(method: str, lmax: int, pixels: int) -> str:
    if method not in METHODS:
        raise ParameterError(f"unknown projection method {method!r}; choose one of {METHODS}")
    if method == "auto":
        return "blas" if lmax <= BLAS_MAX_LMAX and pixels <= BLAS_MAX_PIXELS else "numba"
    return method


def project_latlong_image_frame(img, lmax: int, method: str = "numba") -> np.ndarray:
    """Coefficients in the image frame (see module doc); ``img`` is ``(H, W, C)``."""
    h, w, nc = img.shape
    sums = row_sums(img, lmax, method)
    n = (h + 1) // 2
    theta = np.pi * (np.arange(n) + 0.5) / h
    z, sin_t = np.cos(theta), np.sin(theta)
    weights = fejer_row_weights(h, w)[:n]
    qmm, a, b = recurrence_tables(lmax)
    out = np.empty((n_coeffs(lmax), nc))
    if method != "blas":
        rows = np.ascontiguousarray(sums.transpose(1, 2, 0))  # no copy after the numba kernels
        _legendre_sums(rows, z, weights, sin_t, lmax, qmm, a, b, out)
        return out
    top = sums[:n]
    bottom = sums[::-1][:n]
    plus = top + bottom
    minus = top - bottom
    if h % 2 == 1:  # the equator row is its own mirror
        plus[n - 1] = top[n - 1]
        minus[n - 1] = top[n - 1]
    plus = np.ascontiguousarray(plus.transpose(1, 2, 0))
    minus = np.ascontiguousarray(minus.transpose(1, 2, 0))
    _legendre_sums_numpy(plus, minus, z, weights, sin_t, lmax, qmm, a, b, out)
    return out


def project_latlong(img, lmax: int, method: str = "auto") -> np.ndarray:
    """Project a lat-long radiance image onto real SH in the world frame.

    Parameters
    ----------
    img : ndarray, (H, W, C), float32 or float64
        Radiance, lat-long layout of SPEC §3 (row 0 = +Y, centre = +Z, pixels
        are cells with exact solid angles). Must be finite (validated upstream).
    lmax : int, 0 … 128
    method : ``"auto"``, ``"numba"`` or ``"blas"``
        ``numba``: the folded, blocked kernels (fastest once numba is loaded).
        ``blas``: numpy/BLAS only, nothing compiled or loaded (a process that
        projects one small-``lmax`` map and exits). ``auto``: ``blas`` for
        ``lmax ≤`` :data:`BLAS_MAX_LMAX` on images of at most
        :data:`BLAS_MAX_PIXELS` pixels, else ``numba`` — decided by the input
        alone, so the same input gives the same bytes in any process. The two
        agree to 1e-15 relative (tested), not bit for bit.

    Returns
    -------
    ndarray, ((lmax+1)^2, C), float64
        ``L_lm = Σ_pixels L(ω_p) y_lm(ω_p) w_p`` with Fejér weights ``w_p``
        (exact for content band-limited below ``l = H``).
    """
    lmax = check_lmax(lmax)
    img = np.asarray(img)
    if img.ndim != 3 or img.dtype not in (np.float32, np.float64):
        raise ParameterError(f"expected an (H, W, C) float image, got {img.shape} {img.dtype}")
    method = _choose_method(method, lmax, img.shape[0] * img.shape[1])
    local = project_latlong_image_frame(img, lmax, method)
    if method == "blas":
        return _to_world_blas(lmax) @ local
    return _to_world(lmax).apply(local)


@lru_cache(maxsize=8)
def _to_world(lmax: int) -> SHRotation:
    # c_world = M(IMAGE_FRAME)ᵀ c_image = M(IMAGE_FRAMEᵀ) c_image; a constant per lmax.
    return SHRotation(IMAGE_FRAME.T, lmax)


@lru_cache(maxsize=8)
def _to_world_blas(lmax: int) -> np.ndarray:
    """:func:`_to_world` as a dense ``(n, n)`` matrix, with numpy only (the ``blas`` path).

    Column ``i`` of its transpose is the image-frame projection of the world basis
    function ``y_i``, sampled on a lat-long grid of ``2 lmax+2`` rows and columns: the
    smallest on which this projection is exact for products of two band-``lmax``
    functions (azimuthal frequencies up to ``2 lmax`` below the width; after the azimuth
    sum, polynomials in ``cos θ'`` of degree ``≤ 2 lmax`` below Fejér's ``H`` nodes). So
    ``c_world = Aᵀ c_image`` holds to rounding, with no rotation recurrence to run
    interpreted (~6 ms at lmax 8); entries between different bands are exactly zero.
    """
    n = 2 * lmax + 2
    theta = np.pi * (np.arange(n) + 0.5) / n
    phi = -2.0 * np.pi * (np.arange(n) + 0.5) / n
    image_dirs = np.stack(
        [
            np.outer(np.sin(theta), np.cos(phi)),
            np.outer(np.sin(theta), np.sin(phi)),
            np.repeat(np.cos(theta)[:, None], n, axis=1),
        ],
        axis=-1,
    )
    world_basis = real_sh(image_dirs @ IMAGE_FRAME, lmax)  # d = IMAGE_FRAMEᵀ d'
    a = project_latlong_image_frame(world_basis, lmax, "blas")
    bands = band_of_index(lmax)
    a[bands[:, None] != bands[None, :]] = 0.0
    matrix = np.ascontiguousarray(a.T)
    matrix.flags.writeable = False
    return matrix


def project_samples(dirs, weights, values, lmax: int, chunk: int = 65536) -> np.ndarray:
    """``Σ_k values_k y(dirs_k) weights_k`` — projection of any weighted sample set.

    Parameters
    ----------
    dirs : (N, 3) unit vectors; weights : (N,) solid angles in sr;
    values : (N, C) radiance.
    """
    lmax = check_lmax(lmax)
    dirs = np.asarray(dirs, dtype=np.float64)
    wv = np.asarray(values, dtype=np.float64) * np.asarray(weights, dtype=np.float64)[:, None]
    out = np.zeros((n_coeffs(lmax), wv.shape[1]))
    for s in range(0, dirs.shape[0], chunk):
        out += real_sh_numba(dirs[s : s + chunk], lmax).T @ wv[s : s + chunk]
    return out
