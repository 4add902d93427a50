"""Rotation of real SH coefficients (SPEC §2).

A rotation ``R`` (3×3, proper) acts block-diagonally, one ``(2l+1)²`` block per
band. shbake's matrix ``M(R)`` is defined by::

    y(R d) = M(R) y(d)        for every unit vector d,

so that rotating a function, ``g(d) = f(Rᵀ d)``, maps its coefficients as
``c_g = M(R) c_f``, and ``M(AB) = M(A) M(B)``.

Blocks are built by the Ivanic–Ruedenberg recurrence (J. Phys. Chem. 100,
6342 (1996), with the 1998 erratum) from the ``l = 1`` block, which in the
basis order ``(y, z, x)`` is ``R`` permuted: ``M_1[i, j] = R[p(i), p(j)]``,
``p = (1, 2, 0)``. Measured deviation from orthogonality of the band-``l``
block for a random rotation: 2e-14 at l = 30, 9e-12 at 64, 7e-9 at 96,
6e-6 at 128 (rounding grows with l in this recurrence; SPEC asks 1e-10 to 30).
"""

import numpy as np

from shbake.conventions import check_lmax, lmax_of, n_coeffs
from shbake.errors import ParameterError
from shbake.jit import jit


def check_rotation(R) -> np.ndarray:
    """Validate a proper 3×3 rotation matrix (orthonormal to 1e-9, det +1)."""
    R = np.asarray(R, dtype=np.float64)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ParameterError(f"a rotation must be a finite 3x3 matrix, got shape {R.shape}")
    if np.abs(R @ R.T - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0:
        raise ParameterError("matrix is not a proper rotation (R Rᵀ = I, det R = +1)")
    return R


def block_offsets(lmax: int) -> np.ndarray:
    """Start of each band's ``(2l+1)²`` block in the flat storage, and the total, ``(lmax+2,)``."""
    sizes = (2 * np.arange(lmax + 1) + 1) ** 2
    return np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)


@jit
def rotation_coefficients(lmax, offsets, uvw):
    """The ``u, v, w`` factors of Ivanic–Ruedenberg for every ``(l, m, n)``, ``l ≥ 2``.

    ``uvw[3 k + 0/1/2]`` with ``k = offsets[l] + (m+l)(2l+1) + (n+l)`` — the
    flat index of the block entry. They depend on ``lmax`` only, so a caller
    rotating many frames computes them once (:func:`rotation_blocks_with`).
    """
    for l in range(2, lmax + 1):
        size = 2 * l + 1
        for m in range(-l, l + 1):
            am = abs(m)
            d = 1.0 if m == 0 else 0.0
            for n in range(-l, l + 1):
                if abs(n) < l:
                    denom = (l + n) * (l - n)
                else:
                    denom = 2 * l * (2 * l - 1)
                k = 3 * (offsets[l] + (m + l) * size + (n + l))
                uvw[k] = np.sqrt((l + m) * (l - m) / denom)
                uvw[k + 1] = (
                    0.5 * np.sqrt((1.0 + d) * (l + am - 1) * (l + am) / denom) * (1.0 - 2.0 * d)
                )
                uvw[k + 2] = -0.5 * np.sqrt((l - am - 1) * (l - am) / denom) * (1.0 - d)


@jit
def p_rows(lmax):
    """Rows of the ``P`` scratch of :func:`rotation_blocks_many` (the last one is all zeros)."""
    return 3 * max(2 * lmax - 1, 1) * (2 * lmax + 1) + 1


@jit
def rotation_blocks_many(r1, lmax, offsets, uvw, pbuf, out, nb):
    """The flat blocks of ``nb`` rotations at once, vectorised across them (check-free kernel).

    ``r1`` is ``(3, 3, B)``: the ``l = 1`` blocks (``R`` permuted, module
    docstring) of rotations ``k < nb``; ``out`` is ``(offsets[-1], B)``, entry
    ``e`` of rotation ``k`` at ``out[e, k]``; ``pbuf`` is ``(p_rows(lmax), B)``
    scratch; ``uvw`` from :func:`rotation_coefficients`.

    Ivanic–Ruedenberg per band ``l ≥ 2``: first the helper
    ``P(i, a, b) = R_i,· · M_{l-1}[a, ·]`` (their eq. 5.x: one product for
    ``|b| < l``, two at ``b = ±l``) for every ``i ∈ {-1, 0, 1}``, ``|a| < l``,
    ``|b| ≤ l``; then every entry ``u P(0, m, n) + v V + w W`` with ``V, W``
    the sums of ``P`` of the paper's table (absent terms read the zero row).
    Every loop runs over the rotations, so it vectorises; the arithmetic of
    each entry is the same, in the same order, as for one rotation
    (:func:`rotation_blocks_with` calls this with ``B = 1``).
    """
    zero = pbuf.shape[0] - 1
    for k in range(nb):
        out[0, k] = 1.0
        pbuf[zero, k] = 0.0
    if lmax == 0:
        return
    for i in range(3):
        for j in range(3):
            for k in range(nb):
                out[offsets[1] + 3 * i + j, k] = r1[i, j, k]
    for l in range(2, lmax + 1):
        size = 2 * l + 1
        psize = 2 * l - 1
        o = l - 1
        po = offsets[l - 1]
        for i in range(3):  # P(i - 1, a, b)
            for a in range(psize):
                row = po + a * psize
                for b in range(size):
                    idx = (i * psize + a) * size + b
                    if b == size - 1:  # b = l
                        for k in range(nb):
                            pbuf[idx, k] = (
                                r1[i, 2, k] * out[row + 2 * o, k] - r1[i, 0, k] * out[row, k]
                            )
                    elif b == 0:  # b = -l
                        for k in range(nb):
                            pbuf[idx, k] = (
                                r1[i, 2, k] * out[row, k] + r1[i, 0, k] * out[row + 2 * o, k]
                            )
                    else:
                        for k in range(nb):
                            pbuf[idx, k] = r1[i, 1, k] * out[row + b - 1, k]
        for m in range(-l, l + 1):
            am = abs(m)
            dm = 1.0 if am == 1 else 0.0
            for n in range(-l, l + 1):
                e = offsets[l] + (m + l) * size + (n + l)
                u = uvw[3 * e]
                v = uvw[3 * e + 1]
                w = uvw[3 * e + 2]
                nb_ = n + l
                # rows of P(i, a, n): ((i+1) psize + a + o) size + n + l
                ia = ((1 * psize + m + o) * size + nb_) if u != 0.0 else zero
                ib = ic = id_ = ie = zero
                g = 1.0
                sc = 1.0
                se = 1.0
                if v != 0.0:
                    if m == 0:
                        ib = (2 * psize + 1 + o) * size + nb_
                        ic = (0 * psize - 1 + o) * size + nb_
                    elif m > 0:
                        g = np.sqrt(1.0 + dm)
                        ib = (2 * psize + m - 1 + o) * size + nb_
                        if dm == 0.0:
                            ic = (0 * psize - m + 1 + o) * size + nb_
                            sc = -1.0
                    else:
                        g = np.sqrt(1.0 + dm)
                        ib = (0 * psize - m - 1 + o) * size + nb_
                        if dm == 0.0:
                            ic = (2 * psize + m + 1 + o) * size + nb_
                if w != 0.0:
                    if m > 0:
                        id_ = (2 * psize + m + 1 + o) * size + nb_
                        ie = (0 * psize - m - 1 + o) * size + nb_
                    else:
                        id_ = (2 * psize + m - 1 + o) * size + nb_
                        ie = (0 * psize - m + 1 + o) * size + nb_
                        se = -1.0
                for k in range(nb):
                    val = 0.0 + u * pbuf[ia, k]
                    val += v * (pbuf[ib, k] * g + sc * pbuf[ic, k])
                    val += w * (pbuf[id_, k] + se * pbuf[ie, k])
                    out[e, k] = val


@jit
def rotation_blocks_with(r1, lmax, offsets, uvw, out):
    """:func:`rotation_blocks` with the factors of :func:`rotation_coefficients` given
    (one rotation: :func:`rotation_blocks_many` with ``B = 1``)."""
    pbuf = np.empty((p_rows(lmax), 1))
    rotation_blocks_many(
        r1.reshape((3, 3, 1)), lmax, offsets, uvw, pbuf, out.reshape((out.shape[0], 1)), 1
    )


@jit
def rotation_blocks(r1, lmax, offsets, out):
    """Fill the flat block storage ``out`` for bands 0…lmax (check-free kernel).

    ``r1`` is the ``l = 1`` block (``R`` permuted to the basis order ``(y, z, x)``,
    module docstring), ``offsets`` from :func:`block_offsets`.
    """
    uvw = np.empty(3 * offsets[-1])
    rotation_coefficients(lmax, offsets, uvw)
    rotation_blocks_with(r1, lmax, offsets, uvw, out)


class SHRotation:
    """The SH representation ``M(R)`` of a rotation, stored as per-band blocks.

    Parameters
    ----------
    R : array_like, (3, 3)
        Proper rotation acting on world directions.
    lmax : int, 0 … 128
    """

    def __init__(self, R, lmax: int):
        self.R = check_rotation(R)
        self.lmax = check_lmax(lmax)
        self._offsets = block_offsets(self.lmax)
        perm = [1, 2, 0]
        r1 = np.ascontiguousarray(self.R[np.ix_(perm, perm)])
        self._flat = np.zeros(self._offsets[-1])
        rotation_blocks(r1, self.lmax, self._offsets, self._flat)

    def block(self, l: int) -> np.ndarray:
        """The ``(2l+1, 2l+1)`` block of band ``l`` (rows/cols ``m = -l … l``)."""
        size = 2 * l + 1
        return self._flat[self._offsets[l] : self._offsets[l + 1]].reshape(size, size)

    def dense(self) -> np.ndarray:
        """The full ``(n, n)`` block-diagonal matrix (for tests and small ``lmax``)."""
        n = n_coeffs(self.lmax)
        out = np.zeros((n, n))
        for l in range(self.lmax + 1):
            out[l * l : (l + 1) ** 2, l * l : (l + 1) ** 2] = self.block(l)
        return out

    def apply(self, coeffs, transpose: bool = False) -> np.ndarray:
        """Return ``M(R) @ coeffs`` (or ``M(R)ᵀ @ coeffs``), coeffs shaped ``(n, ...)``.

        ``coeffs`` may have fewer bands than ``lmax``; it may not have more.
        """
        c = np.asarray(coeffs, dtype=np.float64)
        n = c.shape[0]
        lmax_c = lmax_of(n)
        if lmax_c > self.lmax:
            raise ParameterError(
                f"cannot rotate {n} coefficients with an lmax {self.lmax} rotation"
            )
        out = np.empty_like(c)
        flat_in = c.reshape(n, -1)
        flat_out = out.reshape(n, -1)
        for l in range(lmax_c + 1):
            blk = self.block(l)
            s = slice(l * l, (l + 1) ** 2)
            np.matmul(blk.T if transpose else blk, flat_in[s], out=flat_out[s])
        return out


def rotate(coeffs, R) -> np.ndarray:
    """Coefficients of ``g(d) = f(Rᵀ d)`` given those of ``f``: ``M(R) @ coeffs``."""
    c = np.asarray(coeffs, dtype=np.float64)
    return SHRotation(R, lmax_of(c.shape[0])).apply(c)
