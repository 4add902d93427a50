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

from shbake.conventions import check_lmax, n_coeffs
from shbake.errors import ParameterError
from shbake.jit import interpreted, jit, prefetch, run_blocks
from shbake.sh.basis import legendre_next, real_sh_numba, recurrence_tables
from shbake.sh.rotation import SHRotation

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

    ``n = W/4`` when ``W % 4 == 0`` (the quarter-fold kernel), else ``⌈W/2⌉``.
    Column ``W-1-j`` has ``φ' = -φ'_j`` (same cos, opposite sin); for ``W % 4
    == 0`` column ``W/2-1-j`` has ``φ' = -π-φ'_j`` (cos × ``(-1)^m``, sin ×
    ``-(-1)^m``). Read-only.
    """
    n = width // 4 if width % 4 == 0 else (width + 1) // 2
    phi = -2.0 * np.pi * (np.arange(n) + 0.5) / width
    m = np.arange(lmax + 1)
    c = np.ascontiguousarray(np.cos(np.outer(m, phi)))
    s = np.ascontiguousarray(np.sin(np.outer(m, phi)))
    c.flags.writeable = False
    s.flags.writeable = False
    return c, s


COLUMN_BLOCK = 256
"""Folded columns per pass of the row kernels: the folded values of a block
(4 × channels × ``COLUMN_BLOCK`` doubles, 24 KiB for RGB) and the table columns
of the block stay in L1 while every ``m`` reads them."""

_FAST = {"reassoc", "contract"}

PREFETCH_LINES = 4
"""Cache lines prefetched at the start of each of the next row's four column runs while a
row is folded: the hardware prefetcher finds a new stream only after a few misses, and
4 runs start anew on every row (~3 % faster at 4096×2048 lmax 8, same process, A/B)."""

_U = np.uint64


@jit(fastmath=_FAST, inline="always")
def _butterfly4(a, b, c, d, buf, ch, j):
    """Fold the values of columns ``j, W-1-j, W/2-1-j, W/2+j`` (see :func:`_row_sums_quarter`)."""
    sab = a + b
    scd = c + d
    dab = a - b
    dcd = c - d
    buf[0, ch, j] = sab + scd
    buf[1, ch, j] = sab - scd
    buf[2, ch, j] = dab - dcd
    buf[3, ch, j] = dab + dcd


@jit(inline="always")
def _coeff_index(m, sine):
    """Row-sum column of ``cos(mφ')`` (``2m-1``; 0 for m = 0) or ``sin(mφ')`` (``2m``)."""
    if sine:
        return 2 * m
    return 0 if m == 0 else 2 * m - 1


@jit(fastmath=_FAST, inline="always")
def _dots_rgb(buf, kind, nj, j0, table, m, nm, acc, sine):
    """``acc[c, k(m')] += Σ_j buf[kind, c, j] table[m', j0+j]`` for ``m' = m, m+2, … < nm``, RGB.

    A ``(3 × nj) · (nj × ⌈(nm-m)/2⌉)`` product in register tiles of 3 channels
    × 4 ``m`` (7 loads per 12 multiply-adds), then 3 × 2 and 3 × 1 for the rest.
    Check-free kernel.
    """
    x0 = buf[kind, 0, :nj]
    x1 = buf[kind, 1, :nj]
    x2 = buf[kind, 2, :nj]
    while m + 6 < nm:
        t0 = table[m, j0 : j0 + nj]
        t1 = table[m + 2, j0 : j0 + nj]
        t2 = table[m + 4, j0 : j0 + nj]
        t3 = table[m + 6, j0 : j0 + nj]
        a00 = a01 = a02 = a10 = a11 = a12 = a20 = a21 = a22 = a30 = a31 = a32 = 0.0
        for j in range(nj):
            v0 = x0[j]
            v1 = x1[j]
            v2 = x2[j]
            u0 = t0[j]
            u1 = t1[j]
            u2 = t2[j]
            u3 = t3[j]
            a00 += v0 * u0
            a01 += v1 * u0
            a02 += v2 * u0
            a10 += v0 * u1
            a11 += v1 * u1
            a12 += v2 * u1
            a20 += v0 * u2
            a21 += v1 * u2
            a22 += v2 * u2
            a30 += v0 * u3
            a31 += v1 * u3
            a32 += v2 * u3
        k = _coeff_index(m, sine)
        acc[0, k] += a00
        acc[1, k] += a01
        acc[2, k] += a02
        k = _coeff_index(m + 2, sine)
        acc[0, k] += a10
        acc[1, k] += a11
        acc[2, k] += a12
        k = _coeff_index(m + 4, sine)
        acc[0, k] += a20
        acc[1, k] += a21
        acc[2, k] += a22
        k = _coeff_index(m + 6, sine)
        acc[0, k] += a30
        acc[1, k] += a31
        acc[2, k] += a32
        m += 8
    while m + 2 < nm:
        t0 = table[m, j0 : j0 + nj]
        t1 = table[m + 2, j0 : j0 + nj]
        a00 = a01 = a02 = a10 = a11 = a12 = 0.0
        for j in range(nj):
            v0 = x0[j]
            v1 = x1[j]
            v2 = x2[j]
            u0 = t0[j]
            u1 = t1[j]
            a00 += v0 * u0
            a01 += v1 * u0
            a02 += v2 * u0
            a10 += v0 * u1
            a11 += v1 * u1
            a12 += v2 * u1
        k = _coeff_index(m, sine)
        acc[0, k] += a00
        acc[1, k] += a01
        acc[2, k] += a02
        k = _coeff_index(m + 2, sine)
        acc[0, k] += a10
        acc[1, k] += a11
        acc[2, k] += a12
        m += 4
    while m < nm:
        t0 = table[m, j0 : j0 + nj]
        a00 = a01 = a02 = 0.0
        for j in range(nj):
            u0 = t0[j]
            a00 += x0[j] * u0
            a01 += x1[j] * u0
            a02 += x2[j] * u0
        k = _coeff_index(m, sine)
        acc[0, k] += a00
        acc[1, k] += a01
        acc[2, k] += a02
        m += 2


@jit(fastmath=_FAST, inline="always")
def _dots_any(buf, kind, nc, nj, j0, table, m, nm, acc, sine):
    """:func:`_dots_rgb` for any channel count: tiles of 1 channel × 4 ``m``, then 1 × 1."""
    for c in range(nc):
        x = buf[kind, c, :nj]
        mm = m
        while mm + 6 < nm:
            t0 = table[mm, j0 : j0 + nj]
            t1 = table[mm + 2, j0 : j0 + nj]
            t2 = table[mm + 4, j0 : j0 + nj]
            t3 = table[mm + 6, j0 : j0 + nj]
            a0 = a1 = a2 = a3 = 0.0
            for j in range(nj):
                v = x[j]
                a0 += v * t0[j]
                a1 += v * t1[j]
                a2 += v * t2[j]
                a3 += v * t3[j]
            acc[c, _coeff_index(mm, sine)] += a0
            acc[c, _coeff_index(mm + 2, sine)] += a1
            acc[c, _coeff_index(mm + 4, sine)] += a2
            acc[c, _coeff_index(mm + 6, sine)] += a3
            mm += 8
        while mm < nm:
            t0 = table[mm, j0 : j0 + nj]
            a0 = 0.0
            for j in range(nj):
                a0 += x[j] * t0[j]
            acc[c, _coeff_index(mm, sine)] += a0
            mm += 2


@jit(fastmath=_FAST, inline="always")
def _dots(buf, kind, nc, nj, j0, table, m, nm, acc, sine):
    """All ``m' = m, m+2, … < nm`` against folded vector ``kind`` of a column block."""
    if nc == 3:
        _dots_rgb(buf, kind, nj, j0, table, m, nm, acc, sine)
    else:
        _dots_any(buf, kind, nc, nj, j0, table, m, nm, acc, sine)


@jit(fastmath=_FAST)
def _row_sums_quarter(img, cos_t, sin_t, out, b0, b1):
    """Row sums against ``cos/sin(mφ')`` for ``W % 4 == 0``, rows of blocks ``b0 … b1-1``.

    ``out[i, c, 0] = Σ_j img[i, j, c]``, ``out[i, c, 2m-1] = Σ_j img cos(mφ'_j)``,
    ``out[i, c, 2m] = Σ_j img sin(mφ'_j)``. The four columns ``j, W-1-j,
    W/2-1-j, W/2+j`` share ``|cos|, |sin|`` (table doc), so each row is read
    once, folded into four ``W/4``-long vectors per channel — even / odd ``m``
    for cos / sin — a block of :data:`COLUMN_BLOCK` columns at a time, and
    every ``m`` is a dot product with one table row over that block (a
    cache-blocked ``(C × W/4) · (W/4 × 2 lmax+1)`` product, :func:`_dots`).

    The fold reads the row as one flat run of ``W C`` values: columns ``j``
    and ``W/2+j`` forwards, columns ``W-1-j`` and ``W/2-1-j`` backwards with
    unsigned indices (no negative-index wrap, so LLVM sees reversed
    interleaved runs, not gathers), and the RGB fold vectorises
    (de-interleave, float32 → float64, butterflies). No zero-fill, no copy of
    the image. Check-free kernel.
    """
    h, w, nc = img.shape
    nq = w // 4
    half = w // 2
    nm = cos_t.shape[0]
    buf = np.empty((4, nc, COLUMN_BLOCK))  # E (cos, even m), O (cos, odd), DO (sin, even), DE
    acc = np.empty((nc, 2 * nm - 1))
    flat = img.reshape(h * w * nc)
    line = 64 // img.itemsize
    for i in range(b0 * ROWS_PER_BLOCK, min(h, b1 * ROWS_PER_BLOCK)):
        f = img[i].reshape(w * nc)
        acc[:] = 0.0
        if i + 1 < h:  # start the next row's runs (see PREFETCH_LINES)
            g = (i + 1) * w * nc
            for k in range(PREFETCH_LINES):
                prefetch(flat, g + k * line)
                prefetch(flat, g + nc * half + k * line)
                prefetch(flat, g + nc * w - 1 - k * line)
                prefetch(flat, g + nc * half - 1 - k * line)
        for j0 in range(0, nq, COLUMN_BLOCK):
            nj = min(COLUMN_BLOCK, nq - j0)
            fa = f[nc * j0 :]  # column j0 + j
            fd = f[nc * (half + j0) :]  # column W/2 + j0 + j
            rb = _U(nc * (w - 1 - j0))  # column W-1-j0-j starts at rb - C j
            rc = _U(nc * (half - 1 - j0))  # column W/2-1-j0-j starts at rc - C j
            if nc == 3:  # RGB: channels unrolled (one interleaved group per access)
                for j in range(nj):
                    k = 3 * j
                    b = rb - _U(k)
                    c = rc - _U(k)
                    for ch in range(3):
                        _butterfly4(
                            np.float64(fa[k + ch]),
                            np.float64(f[b + _U(ch)]),
                            np.float64(f[c + _U(ch)]),
                            np.float64(fd[k + ch]),
                            buf,
                            ch,
                            j,
                        )
            else:
                for j in range(nj):
                    k = nc * j
                    b = rb - _U(k)
                    c = rc - _U(k)
                    for ch in range(nc):
                        _butterfly4(
                            np.float64(fa[k + ch]),
                            np.float64(f[b + _U(ch)]),
                            np.float64(f[c + _U(ch)]),
                            np.float64(fd[k + ch]),
                            buf,
                            ch,
                            j,
                        )
            _dots(buf, 0, nc, nj, j0, cos_t, 0, nm, acc, False)  # even m: E · cos
            _dots(buf, 1, nc, nj, j0, cos_t, 1, nm, acc, False)  # odd m: O · cos
            _dots(buf, 2, nc, nj, j0, sin_t, 2, nm, acc, True)  # even m > 0: DO · sin
            _dots(buf, 3, nc, nj, j0, sin_t, 1, nm, acc, True)  # odd m: DE · sin
        for c in range(nc):
            for k in range(2 * nm - 1):
                out[c, k, i] = acc[c, k]


@jit(fastmath=_FAST)
def _row_sums_half(img, cos_t, sin_t, out, b0, b1):
    """As :func:`_row_sums_quarter` for any width: columns ``j`` and ``W-1-j`` folded (sum,
    difference; the middle column of an odd width is its own pair). Check-free kernel."""
    h, w, nc = img.shape
    nh = cos_t.shape[1]
    pairs = w // 2
    nm = cos_t.shape[0]
    buf = np.empty((2, nc, COLUMN_BLOCK))  # sum (cos), difference (sin)
    acc = np.empty((nc, 2 * nm - 1))
    for i in range(b0 * ROWS_PER_BLOCK, min(h, b1 * ROWS_PER_BLOCK)):
        f = img[i].reshape(w * nc)
        acc[:] = 0.0
        for j0 in range(0, nh, COLUMN_BLOCK):
            nj = min(COLUMN_BLOCK, nh - j0)
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
            _dots(buf, 0, nc, nj, j0, cos_t, 0, nm, acc, False)
            _dots(buf, 0, nc, nj, j0, cos_t, 1, nm, acc, False)
            _dots(buf, 1, nc, nj, j0, sin_t, 1, nm, acc, True)
            _dots(buf, 1, nc, nj, j0, sin_t, 2, nm, acc, True)
        for c in range(nc):
            for k in range(2 * nm - 1):
                out[c, k, i] = acc[c, k]


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
    chunks — one strided cast, ``(R, W, C) → (R, C, W)`` — and one ``(R C × W) · (W × 2 lmax+1)``
    matrix product per chunk against the whole-row table."""
    h, w, nc = img.shape
    table = _full_table(w, lmax)
    out = np.empty((h, nc, 2 * lmax + 1))
    rows = max(1, (4 << 20) // (w * nc * 8))
    buf = np.empty((min(rows, h), nc, w))
    for r0 in range(0, h, rows):
        r1 = min(h, r0 + rows)
        chunk = buf[: r1 - r0]
        np.copyto(chunk, img[r0:r1].transpose(0, 2, 1))
        np.matmul(chunk.reshape(-1, w), table, out=out[r0:r1].reshape(-1, 2 * lmax + 1))
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
        with interpreted():  # a few ms of Python instead of loading numba for the rotation
            rot = _to_world(lmax)
    else:
        rot = _to_world(lmax)
    return rot.apply(local)


@lru_cache(maxsize=8)
def _to_world(lmax: int) -> SHRotation:
    # c_world = M(IMAGE_FRAME)ᵀ c_image = M(IMAGE_FRAMEᵀ) c_image; a constant per lmax.
    return SHRotation(IMAGE_FRAME.T, lmax)


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
