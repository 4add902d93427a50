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

from shbake.errors import InputError, ParameterError

LMAX_LIMIT = 128
"""Largest ``lmax`` shbake accepts anywhere."""
KAUTZ_LMAX_LIMIT = 16
"""Largest ``lmax`` of a BRDF table (Kautz et al. 2002 use 4–6; the quadrature grows as lmax²)."""
SH_TARGETS_LMAX_LIMIT = 24
"""Largest lighting ``lmax`` of the SH-exp fit's SH targets (``--targets sh``)."""
DFG_MU_MIN = 1e-3
"""Smallest ``n·v`` on the DFG table's axis (grazing views read this row)."""
DFG_SIZE = 32
"""Nodes per axis of the DFG table."""
DFG_SAMPLES = 8192
"""Quadrature samples per DFG table entry."""
SHEXP_LMAX_LIMIT = 8
"""Largest ``lmax`` of the SH-exp ``P`` and ``Q`` expansions."""
ROUGHNESS_MIN = 0.02
"""Smallest perceptual roughness the GGX integrals accept (GGX width 4e-4)."""

FORMAT_NAME = "shbake"
FORMAT_VERSION = 1

BASIS = "real_orthonormal"
PHASE = "no_condon_shortley"
INDEXING = "l*(l+1)+m"
FRAME = "right_handed"
UP_AXIS = "+Y"
RADIANCE_UNITS = "linear scene-referred RGB radiance (Rec.709 primaries)"

SQRT_4PI = float(np.sqrt(4.0 * np.pi))
"""``sqrt(4π)``: ``Q = sqrt(4π) c_0`` is the white-furnace value of SH coefficients."""

REC709_LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
"""Rec.709 luminance weights, used wherever a scalar brightness is needed."""
DISPLAY_TRANSFORMS = ("reinhard", "aces")
"""Display transforms of the images for people (``--display``): Reinhard on luminance (hue
kept) or the ACES filmic curve per channel, as engines show it
(:func:`shbake.format.images.aces_filmic`)."""


def n_coeffs(lmax: int) -> int:
    """Number of coefficients of a set with highest band ``lmax``: ``(lmax+1)^2``.

    >>> n_coeffs(2)
    9
    """
    return (lmax + 1) ** 2


def lmax_of(n: int) -> int:
    """Inverse of :func:`n_coeffs`; raises if ``n`` is not a perfect square.

    >>> lmax_of(9)
    2
    """
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


def ggx_alpha(roughness):
    """GGX width ``α = r²`` of perceptual roughness ``r`` (Burley 2012; SPEC §1): a float
    for a number, an array for an array.

    >>> ggx_alpha(0.5)
    0.25
    >>> ggx_alpha([0.1, 1.0]).tolist()
    [0.010000000000000002, 1.0]
    """
    a = np.asarray(roughness, dtype=float) ** 2
    return float(a) if a.ndim == 0 else a


def perceptual_roughness(alpha):
    """Perceptual roughness ``r = sqrt(α)`` of GGX width ``α``, the inverse of
    :func:`ggx_alpha` (a float for a number, an array for an array).

    >>> perceptual_roughness(0.25)
    0.5
    """
    r = np.sqrt(np.asarray(alpha, dtype=float))
    return float(r) if r.ndim == 0 else r


SAMPLES_LIMIT = 1 << 20
"""Most quadrature samples per integral any option accepts."""


def check_roughness(r, lo: float = ROUGHNESS_MIN, hi: float = 1.0, name: str = "roughness"):
    """Refuse perceptual roughness outside ``[lo, hi]`` (or non-finite); returns the array."""
    a = np.asarray(r, dtype=float)
    if not np.all(np.isfinite(a)) or np.any(a < lo - 1e-12) or np.any(a > hi + 1e-12):
        raise ParameterError(f"{name} must lie in [{lo:g}, {hi:g}], got {np.ravel(a)[:4]}")
    return a


def check_samples(n, lo: int = 16, hi: int = SAMPLES_LIMIT, name: str = "samples") -> int:
    """Validate a sample count given by a user; return it as ``int``."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or not lo <= n <= hi:
        raise ParameterError(f"{name} must be an integer in [{lo}, {hi}], got {n}")
    return int(n)


FLOAT32_MAX = float(np.finfo(np.float32).max)
"""Largest finite float32 (3.4028235e38): the most a map's texel (decoded as float32) or a
float32 dataset, texture or image holds."""


def to_float32(values, source: str, step: str) -> np.ndarray:
    """``values`` as float32, refused in one line (:class:`~shbake.errors.InputError`:
    ``SOURCE: values too large to store in float32 after STEP (largest …)``) where a finite
    value rounds beyond :data:`FLOAT32_MAX`, which a plain cast stores as ±inf with numpy's
    "overflow encountered in cast"; NaN and ±inf already there pass as they are.
    ``source`` names the input the values come from (a map), ``step`` what made them.

    >>> to_float32([1.0, 3e38], "sky.exr", "x").dtype
    dtype('float32')
    >>> to_float32([1e39], "m.exr", "x")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    shbake.errors.InputError: m.exr: values too large to store in float32 after x (largest 1e+39...
    """
    a = np.asarray(values)
    with np.errstate(over="ignore"):
        out = a.astype(np.float32)
    if np.isfinite(out).all():
        return out
    over = np.isinf(out) & np.isfinite(a)
    if over.any():
        peak = float(np.abs(a[over]).max())
        raise InputError(f"{source}: values too large to store in float32 after {step} "
                         f"(largest {peak:.4g}; float32 holds at most {FLOAT32_MAX:.4g}): "
                         "scale the map down")  # fmt: skip
    return out


CUBE_FACES = (
    ("+X", ((0, 0, 1), (0, -1, 0), (1, 0, 0))),
    ("-X", ((0, 0, -1), (0, -1, 0), (-1, 0, 0))),
    ("+Y", ((1, 0, 0), (0, 0, 1), (0, -1, 0))),
    ("-Y", ((1, 0, 0), (0, 0, -1), (0, 1, 0))),
    ("+Z", ((-1, 0, 0), (0, -1, 0), (0, 0, 1))),
    ("-Z", ((1, 0, 0), (0, -1, 0), (0, 0, -1))),
)
"""Cube faces of OpenEXR ``envmap = cube`` (SPEC §3) in strip order, each with the matrix
``A`` of its orientation: direction ``= A @ (s, t, 1)``, ``s`` left → right and ``t`` top →
bottom in ``[-1, 1]``. Used by the cube-strip input layout and the cube-map textures."""


def check_vectors(v, name: str = "directions") -> np.ndarray:
    """``v`` as a float64 array ``(..., 3)`` of finite, non-zero vectors (not normalised).

    About 3 ns per vector: cheaper than any kernel that reads them (a per-row
    ``abs().max(axis=-1)`` or ``linalg.norm`` costs 20–45 ns per vector).
    """
    d = np.asarray(v, dtype=np.float64)
    if d.shape[-1:] != (3,):
        raise ParameterError(f"{name} must have a last axis of 3, got shape {d.shape}")
    if not np.isfinite(d).all():
        raise ParameterError(f"{name} must be finite")
    x, y, z = np.moveaxis(d, -1, 0)
    if ((x == 0.0) & (y == 0.0) & (z == 0.0)).any():
        raise ParameterError(f"{name} must be non-zero vectors")
    return d


def unit_vectors(v, name: str = "directions") -> np.ndarray:
    """``v`` (checked by :func:`check_vectors`) normalised to unit length, float64 ``(..., 3)``.

    Each vector is divided by its largest absolute component first, so any finite
    non-zero magnitude works (1e-300 or 1e300: no underflow or overflow in the norm).
    Column by column (x, y, z): ~50 ns per vector where ``abs().max(axis=-1)`` and
    ``linalg.norm(axis=-1)`` took ~125, with the same rounding.
    """
    d = check_vectors(v, name)
    x, y, z = np.moveaxis(d, -1, 0)
    big = np.maximum(np.maximum(np.abs(x), np.abs(y)), np.abs(z))
    x, y, z = x / big, y / big, z / big
    norm = np.sqrt((x * x + y * y) + z * z)
    out = np.empty_like(d)
    out[..., 0] = x / norm
    out[..., 1] = y / norm
    out[..., 2] = z / norm
    return out
