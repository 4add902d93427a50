"""Conventions shared by every part of shbake (SPEC §1–3, ``docs/CONVENTIONS.md``).

SH basis
    Real, orthonormal, no Condon–Shortley phase, index ``i = l*(l+1) + m``;
    ``m < 0`` ↔ ``sin(|m| φ)``, ``m > 0`` ↔ ``cos(m φ)``, with ``θ`` from +Z and
    ``φ`` from +X toward +Y of the frame the function lives in.
World frame
    Right-handed, +Y up (glTF, Mitsuba 3).
Local shading frame
    normal +Z, tangent +X, bitangent +Y.
Units
    Radiance is linear scene-referred RGB (Rec.709 primaries); solid angles in
    steradians; irradiance in radiance × sr.
"""

import numpy as np

from shbake.errors import ParameterError

LMAX_LIMIT = 128
"""Largest ``lmax`` shbake accepts anywhere."""

FORMAT_NAME = "shbake"
FORMAT_VERSION = 1

BASIS = "real_orthonormal"
PHASE = "no_condon_shortley"
INDEXING = "l*(l+1)+m"
FRAME = "right_handed"
UP_AXIS = "+Y"
RADIANCE_UNITS = "linear scene-referred RGB radiance (Rec.709 primaries)"

REC709_LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
"""Rec.709 luminance weights, used wherever a scalar brightness is needed."""


def sh_index(l: int, m: int) -> int:
    """Flat index of coefficient ``(l, m)``: ``l*(l+1) + m``."""
    return l * (l + 1) + m


def n_coeffs(lmax: int) -> int:
    """Number of coefficients of a set with highest band ``lmax``: ``(lmax+1)^2``."""
    return (lmax + 1) ** 2


def lmax_of(n: int) -> int:
    """Inverse of :func:`n_coeffs`; raises if ``n`` is not a perfect square."""
    lmax = int(round(np.sqrt(n))) - 1
    if n_coeffs(lmax) != n:
        raise ParameterError(f"{n} coefficients is not (lmax+1)^2 for any lmax")
    return lmax


def band_of_index(lmax: int) -> np.ndarray:
    """Band ``l`` of each flat index ``0 … (lmax+1)^2 - 1``."""
    return np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)


def check_lmax(lmax, name: str = "lmax", limit: int = LMAX_LIMIT) -> int:
    """Validate an ``lmax`` given by a user; return it as ``int``."""
    if isinstance(lmax, bool) or not isinstance(lmax, int | np.integer):
        raise ParameterError(f"{name} must be an integer, got {lmax!r}")
    if not 0 <= int(lmax) <= limit:
        raise ParameterError(f"{name} must be in [0, {limit}], got {lmax}")
    return int(lmax)
