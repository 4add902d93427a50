"""Measured isotropic BRDFs in the MERL ``.binary`` format (Matusik et al. 2003).

File layout (little-endian): three ``int32`` dimensions ``(90, 90, 180)`` =
``(θ_h, θ_d, φ_d)`` bins, then ``3 × 90·90·180`` ``float64`` values, all red,
then green, then blue, stored divided by the channel scales
``(1/1500, 1.15/1500, 1.66/1500)``. Negative values mark missing data.

Sample ``(i, j, k)`` sits at ``θ_h = (i/90)² π/2``, ``θ_d = j π/180``,
``φ_d = k π/180`` (the MERL index maps read as grid points; ``φ_d`` has period
π by reciprocity). :func:`evaluate` converts ``(s, v)`` to Rusinkiewicz's
half/difference angles and interpolates trilinearly in index space (missing
values read as 0, ``θ`` beyond the last sample clamps, ``φ_d`` wraps).
"""

import os

import numpy as np

from shbake import resources
from shbake.brdf.phong import mirror_lobe_pdf, mirror_lobe_sample
from shbake.brdf.spec import ModelSpec, Param
from shbake.errors import InputError, ResourceError, ShbakeError
from shbake.jit import jit

N_TH, N_TD, N_PD = 90, 90, 180
SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])

SPEC = ModelSpec(
    name="merl",
    model_id=7,
    params=(
        Param(
            "lobe",
            64.0,
            0.0,
            1e5,
            doc="sampling hint only: exponent of the Phong lobe importance-sampled "
            "beside the cosine (does not change the BRDF)",
        ),
    ),
    citation="W. Matusik, H. Pfister, M. Brand, L. McMillan, A data-driven reflectance "
    "model, SIGGRAPH 2003; S. Rusinkiewicz, A new change of variables for efficient BRDF "
    "representation, EGWR 1998",
    summary="measured isotropic BRDF read from a MERL .binary file",
)


_last_read: dict = {}
"""The last MERL file decoded, ``{(absolute path, inode, size, mtime): (values, digest)}``:
a reference drawn in blocks of pixels (``shbake.preview.passes.TRUTH_CHUNKS``) builds its
BRDF once per block, and reads the file once."""


def read_merl(path: str) -> tuple[np.ndarray, str]:
    """Read a MERL ``.binary`` file; return its ``(3, 90, 90, 180)`` float64 BRDF values
    (1/sr; shared by every BRDF built from the file, never written) and the hex SHA-256 of
    the bytes they were decoded from (read once: what an asset records of the file is what
    was baked, even if the file changes afterwards). The same file unchanged since
    (:data:`_last_read`) is not read again.

    Raises :class:`~shbake.errors.InputError` for a missing, truncated or
    malformed file, or non-finite values.
    """
    identity = resources.file_identity(os.fspath(path))
    key = None if identity is None else (os.path.abspath(path), *identity)
    if key in _last_read:
        return _last_read[key]
    decoded = _decode_merl(path)
    if key is not None and resources.file_identity(os.fspath(path)) == identity:
        _last_read.clear()
        _last_read[key] = decoded
    return decoded


def _decode_merl(path: str) -> tuple[np.ndarray, str]:
    import hashlib  # as in resources.sha256_of: only a measured BRDF pays for it

    expected = 12 + 3 * 8 * N_TH * N_TD * N_PD
    try:  # special files refused before opening; never more than the format's size read
        raw = resources.read_bounded(os.fspath(path), expected, "MERL file (--merl)")
    except ResourceError as e:
        raise InputError(str(e)) from None
    except ShbakeError:  # missing or unreadable, refused before opening: one line already
        raise
    except OSError as e:
        raise InputError(f"{path}: cannot read MERL file ({e.strerror})") from None
    if len(raw) < 12:
        raise InputError(f"{path}: not a MERL .binary file (only {len(raw)} bytes)")
    dims = tuple(int(d) for d in np.frombuffer(raw[:12], dtype="<i4"))
    if dims != (N_TH, N_TD, N_PD):
        # the header is not echoed: a scene may name any file as its MERL BRDF
        raise InputError(f"{path}: not a MERL .binary file (its header does not hold the "
                         f"dimensions {N_TH} {N_TD} {N_PD})")  # fmt: skip
    n = N_TH * N_TD * N_PD
    if len(raw) != 12 + 3 * 8 * n:
        raise InputError(
            f"{path}: truncated or padded MERL file ({len(raw)} bytes, expected {12 + 24 * n})"
        )
    vals = np.frombuffer(raw[12:], dtype="<f8").reshape(3, N_TH, N_TD, N_PD)
    if not np.all(np.isfinite(vals)):
        raise InputError(f"{path}: MERL file holds NaN or Inf values")
    values = np.ascontiguousarray(np.maximum(vals, 0.0) * SCALES[:, None, None, None])
    return values, hashlib.sha256(raw).hexdigest()


def half_diff_grid() -> tuple[np.ndarray, np.ndarray]:
    """Light and view directions ``(s, v)``, each ``(90, 90, 180, 3)``, of every MERL sample."""
    th = (np.arange(N_TH) / N_TH) ** 2 * (np.pi / 2)
    td = np.arange(N_TD) * (np.pi / 2) / N_TD
    pd = np.arange(N_PD) * np.pi / N_PD
    th, td, pd = np.meshgrid(th, td, pd, indexing="ij")
    d = np.stack([np.sin(td) * np.cos(pd), np.sin(td) * np.sin(pd), np.cos(td)], axis=-1)
    e = d * np.array([-1.0, -1.0, 1.0])  # the other direction, mirrored about h = +Z

    def rot_y(w):
        c, s = np.cos(th), np.sin(th)
        return np.stack(
            [w[..., 0] * c + w[..., 2] * s, w[..., 1], -w[..., 0] * s + w[..., 2] * c], -1
        )

    return rot_y(d), rot_y(e)


@jit
def evaluate_data(data, sx, sy, sz, vx, vy, vz, out):
    """Trilinear look-up of ``data (3, 90, 90, 180)`` at the half/difference angles."""
    if sz <= 0.0 or vz <= 0.0:
        for c in range(3):
            out[c] = 0.0
        return
    hx, hy, hz = sx + vx, sy + vy, sz + vz
    n = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / n, hy / n, hz / n
    th = np.arccos(min(1.0, hz))
    ph = np.arctan2(hy, hx)
    cp, sp = np.cos(ph), np.sin(ph)
    ax, ay, az = sx * cp + sy * sp, -sx * sp + sy * cp, sz  # rotate by −φ_h about z
    ct, st = np.cos(th), np.sin(th)
    dx, dy, dz = ax * ct - az * st, ay, ax * st + az * ct  # rotate by −θ_h about y
    td = np.arccos(min(1.0, max(-1.0, dz)))
    pd = np.arctan2(dy, dx)
    if pd < 0.0:
        pd += np.pi
    fi = min(np.sqrt(th / (0.5 * np.pi)) * N_TH, N_TH - 1.0)
    fj = min(td / (0.5 * np.pi) * N_TD, N_TD - 1.0)
    fk = pd / np.pi * N_PD
    i0, j0, k0 = min(int(fi), N_TH - 2), min(int(fj), N_TD - 2), int(fk) % N_PD
    wi, wj, wk = fi - i0, fj - j0, fk - int(fk)
    k1 = (k0 + 1) % N_PD
    for c in range(3):
        acc = 0.0
        for di in range(2):
            a = wi if di else 1.0 - wi
            for dj in range(2):
                b = wj if dj else 1.0 - wj
                row = data[c, i0 + di, j0 + dj]
                acc += a * b * ((1.0 - wk) * row[k0] + wk * row[k1])
        out[c] = acc


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """Phong lobe of exponent ``prm[0]`` about the mirror direction (a sampling hint)."""
    return mirror_lobe_sample(prm[0], vx, vy, vz, ur, ua)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` (1/sr)."""
    return mirror_lobe_pdf(prm[0], sx, sy, sz, vx, vy, vz)
