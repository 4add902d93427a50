"""EXR and PNG output through OpenImageIO, atomic, with explicit overflow checks."""

import os

import numpy as np
import OpenImageIO as oiio

from shbake.conventions import DISPLAY_TRANSFORMS, REC709_LUMINANCE
from shbake.errors import OutputError, ParameterError
from shbake.format.atomic import atomic_path
from shbake.messages import warn

HALF_MAX = 65504.0


def clamp_to_half(
    levels: list, path: str, limit: float = HALF_MAX, kind: str = "half-float"
) -> list:
    """Engine texture levels for a half-float file ``path``: values beyond ±65504 (the largest
    half float) clamped, with ONE warning line on stderr (how many, the peak, what to do).

    Half-float textures (KTX2 ``R16G16B16A16_SFLOAT``, Filament's KTX) cannot hold more;
    an engine clamps (or shows Inf) anyway, and the clamped texels are at least 65504 —
    brighter than any display. The light lost is the excess of those texels only; a sun is
    better sent as a light (``--extract-sun``, the scene planner does when it finds one).
    Non-finite values are refused (:class:`OutputError`): they are a bug, not a bright map.
    Levels that need no clamp are returned as they are (same bytes as before).
    ``limit``/``kind``: another format's largest value and name (Babylon's RGBD, 255).
    """
    out, count, peak = [], 0, 0.0
    for lv in levels:
        a = np.asarray(lv, dtype=np.float64)
        if not np.all(np.isfinite(a)):
            raise OutputError(f"{path}: refusing to write non-finite values")
        over = np.abs(a) > limit
        if np.any(over):
            count += int(np.count_nonzero(over))
            peak = max(peak, float(np.abs(a).max()))
            a = np.clip(a, -limit, limit)
        out.append(a)
    if count:
        warn(
            f"{path}: {count} values (radiance) above the {kind} maximum {limit:g} (peak "
            f"{peak:.6g}) "
            f"clamped to {limit:g}; send a sun as a light (--extract-sun) to keep its energy"
        )
    return out


def write_exr(
    path: str,
    img: np.ndarray,
    half: bool = True,
    attrs: dict | None = None,
    channel_names: tuple[str, ...] | None = None,
) -> None:
    """Write ``(H, W, C)`` linear data to an EXR (half by default; float32 if ``half=False``).

    Channels are named R, G, B(, A) for 3 or 4 channels, ``c0 …`` otherwise,
    unless ``channel_names`` gives one name per channel.

    Raises :class:`OutputError` for non-finite values, and for values beyond
    ±65504 when writing half floats (OpenImageIO would silently store Inf).
    """
    img = np.asarray(img, dtype=np.float32)
    if img.ndim == 2:
        img = img[:, :, None]
    if not np.all(np.isfinite(img)):
        raise OutputError(f"{path}: refusing to write non-finite values")
    peak = float(np.abs(img).max()) if img.size else 0.0
    if half and peak > HALF_MAX:
        raise OutputError(
            f"{path}: value {peak:.6g} overflows half float (max 65504); use float EXR output"
        )
    h, w, c = img.shape
    spec = oiio.ImageSpec(w, h, c, "half" if half else "float")
    if channel_names is None:
        channel_names = (
            ("R", "G", "B", "A")[:c] if c in (3, 4) else tuple(f"c{i}" for i in range(c))
        )
    if len(channel_names) != c:
        raise ValueError(f"{c} channels but {len(channel_names)} names")
    spec.channelnames = tuple(channel_names)
    for k, v in sorted((attrs or {}).items()):
        spec.attribute(k, v)
    _write(path, spec, img)


def write_png(path: str, img8: np.ndarray) -> None:
    """Write an 8-bit ``(H, W, 3)`` image, or ``(H, W, 4)`` with a straight (unassociated)
    alpha stored as given (RGBD data, not a coverage mask), to PNG."""
    img8 = np.ascontiguousarray(img8, dtype=np.uint8)
    h, w, c = img8.shape
    spec = oiio.ImageSpec(w, h, c, "uint8")
    if c == 4:
        spec.attribute("oiio:UnassociatedAlpha", 1)
    _write(path, spec, img8)


FIXED_ATTRIBUTES = {"compression": "zip", "DateTime": ""}
"""Set on every image so identical pixels give identical bytes: a fixed compression, and
no ``DateTime`` (OpenImageIO would stamp the current time, OpenEXR's ``capDate``)."""


def _oiio_error(path, what, text):
    text = " ".join(str(text).split())
    if "No space left" in text:
        return OutputError(f"no space left on device writing {path}")
    if "Read-only file system" in text:
        return OutputError(f"read-only file system writing {path}")
    if any(sign in text for sign in SHORT_WRITE):
        return _short_write(path)
    return OutputError(f"{path}: {what} ({text[:200] or 'unknown error'})")


SHORT_WRITE = ("could only write", "File output failed")
"""How OpenImageIO's PNG writer and OpenEXR report a failed write (no errno given)."""


def _short_write(path):
    """A write of ``path`` failed without an errno: a full disk if its file system is
    full now, else a quota, a file size limit or an I/O error."""
    try:
        full = os.statvfs(os.path.dirname(os.path.abspath(path))).f_bavail == 0
    except OSError:
        full = False
    if full:
        return OutputError(f"no space left on device writing {path}")
    return OutputError(f"cannot write all of {path} (a disk quota, a file size limit or an "
                       "I/O error)")  # fmt: skip


def _write(path, spec, pixels):
    """Write ``pixels`` through OpenImageIO, atomically. A failed write is an error even
    where the writer's calls return success: OpenImageIO's PNG writer reports a short write
    (full disk, file size limit) only through its error state."""
    for k, v in FIXED_ATTRIBUTES.items():
        if k != "compression" or path.lower().endswith(".exr"):
            spec.attribute(k, v)
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create(tmp)
        if out is None:
            raise _oiio_error(path, "cannot create image writer", oiio.geterror())
        ok = False
        try:
            ok = out.open(tmp, spec) and out.write_image(pixels) and not out.has_error
            err = "" if ok else out.geterror()
        finally:
            closed = out.close() and not out.has_error
        if not ok or not closed:
            raise _oiio_error(path, "write failed", err if not ok else out.geterror())
        if path.lower().endswith(".png"):
            check_png(tmp, path)
        elif path.lower().endswith(".exr"):
            check_exr(tmp, path)


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def check_png(tmp: str, path: str) -> None:
    """Refuse a PNG file ``tmp`` (staged for ``path``) that is not whole: the signature,
    then chunks (length, type, data, CRC-32) each with a correct CRC, the last one ``IEND``
    ending at the end of the file (PNG spec §5.3). OpenImageIO's PNG writer drops the
    error of its last buffered write (made at ``close``), so a full disk or a file size
    limit can leave a short file it reports as written."""
    import zlib

    with open(tmp, "rb") as f:
        data = f.read()
    pos, kind = len(PNG_SIGNATURE), b""
    whole = data.startswith(PNG_SIGNATURE)
    while whole and pos < len(data):
        if pos + 12 > len(data):
            whole = False
            break
        length = int.from_bytes(data[pos : pos + 4], "big")
        kind, end = data[pos + 4 : pos + 8], pos + 8 + length
        if end + 4 > len(data) or zlib.crc32(data[pos + 4 : end]) != int.from_bytes(
            data[end : end + 4], "big"
        ):
            whole = False
            break
        pos = end + 4
    if not (whole and kind == b"IEND" and pos == len(data)):
        raise _short_write(path)


EXR_MAGIC = b"\x76\x2f\x31\x01"
EXR_TILED = 0x200
"""The version field's flag of a tiled single-part file (OpenEXR file layout)."""


def check_exr(tmp: str, path: str) -> None:
    """Refuse an OpenEXR file ``tmp`` (staged for ``path``) that is not whole: the magic
    number, a header of attributes ending in a null byte, then the offset table, each
    offset inside the file, and the last chunk (its line or tile coordinates, its data size,
    its data) ending at the end of the file (OpenEXR file layout, single part). OpenEXR
    writes through a buffered stream whose failed writes (full disk, file size limit)
    OpenImageIO reports as success: a file cut at 128 of its 390 bytes was "written"."""
    import struct

    with open(tmp, "rb") as f:
        data = f.read()
    try:
        if data[:4] != EXR_MAGIC:
            raise ValueError
        prefix = 20 if struct.unpack_from("<I", data, 4)[0] & EXR_TILED else 8
        pos = 8
        while data[pos] != 0:  # attribute: name, type (both null-terminated), size, value
            pos = data.index(b"\0", data.index(b"\0", pos) + 1) + 1
            size = struct.unpack_from("<i", data, pos)[0]
            if size < 0:
                raise ValueError
            pos += 4 + size
        start = pos + 1  # the offset table: up to the first chunk, the least offset
        end = last = struct.unpack_from("<Q", data, start)[0]
        for table in range(start, len(data), 8):
            if table >= end:
                break
            offset = struct.unpack_from("<Q", data, table)[0]
            if not start < offset <= len(data) - prefix:
                raise ValueError
            end, last = min(end, offset), max(last, offset)
        size = struct.unpack_from("<i", data, last + prefix - 4)[0]
        whole = last + prefix + size == len(data)
    except (ValueError, IndexError, struct.error):
        whole = False
    if not whole:
        raise _short_write(path)


def auto_exposure(img: np.ndarray) -> float:
    """``0.18 / geometric-mean luminance`` of the non-zero pixels (1 for a black image)."""
    lum = np.maximum(np.asarray(img, dtype=np.float64), 0.0) @ REC709_LUMINANCE
    nz = lum[lum > 0]
    return 0.18 / float(np.exp(np.mean(np.log(nz)))) if nz.size else 1.0


ACES_EXPOSURE = 0.6
"""Narkowicz's pre-scale of linear radiance before his ACES fit (it matches the fit to the
reference RRT+ODT at exposure 1; the post's ``x *= 0.6``)."""


def aces_filmic(x: np.ndarray) -> np.ndarray:
    """Narkowicz's fit of the ACES RRT + sRGB ODT, per channel, to display-linear ``[0, 1]``:
    ``f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`` of ``x`` = 0.6 × radiance,
    clipped to ``[0, 1]`` (K. Narkowicz, "ACES Filmic Tone Mapping Curve", 2016-01-06,
    knarkowicz.wordpress.com; the curve Unreal's and three.js's filmic modes approximate).
    Per channel, as engines apply it: bright colours drift towards white."""
    x = ACES_EXPOSURE * np.maximum(np.asarray(x, dtype=np.float64), 0.0)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def tonemap(
    img: np.ndarray, exposure: float | None = None, display: str = "reinhard"
) -> np.ndarray:
    """Tone-map linear RGB to display sRGB in ``[0, 1]`` for looking at.

    ``exposure`` (a multiplier; default :func:`auto_exposure`) scales the
    radiance. ``display`` (:data:`DISPLAY_TRANSFORMS`): ``reinhard`` applies
    Reinhard's curve ``Y/(1+Y)`` to the Rec.709 luminance ``Y`` and scales
    every channel by the same factor (so a white sphere under coloured light
    keeps its colour instead of turning grey, as a per-channel curve does),
    channels above 1 clipped; ``aces`` the filmic curve per channel
    (:func:`aces_filmic`). Then the sRGB transfer function. Deterministic.
    """
    if display not in DISPLAY_TRANSFORMS:
        raise ParameterError(f"display transform {display!r}: one of "
                             f"{', '.join(DISPLAY_TRANSFORMS)}")  # fmt: skip
    x = np.maximum(np.asarray(img, dtype=np.float64), 0.0)
    if exposure is None:
        exposure = auto_exposure(x)
    x = x * exposure
    if display == "aces":
        x = aces_filmic(x)
    else:
        lum = x @ REC709_LUMINANCE
        scale = np.where(lum > 0.0, 1.0 / (1.0 + lum), 1.0)
        x = np.minimum(x * scale[..., None], 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def tonemap_to_srgb8(
    img: np.ndarray, exposure: float | None = None, display: str = "reinhard"
) -> np.ndarray:
    """:func:`tonemap` rounded to 8-bit sRGB."""
    return np.clip(np.round(tonemap(img, exposure, display) * 255.0), 0, 255).astype(np.uint8)


def diverging8(x: np.ndarray) -> np.ndarray:
    """``x ∈ [−1, 1]`` → red (positive) / blue (negative) on black, 8-bit ``(…, 3)``."""
    r = np.clip(x, 0, 1)
    b = np.clip(-x, 0, 1)
    rgb = np.stack([r, 0.15 * (r + b), b], axis=-1)
    return np.round(255 * np.sqrt(rgb)).astype(np.uint8)


STRIP_GAP = 2
STRIP_BACKGROUND = 40


def component_strip(components: np.ndarray) -> np.ndarray:
    """A PNG-ready look at signed coefficients ``(H, W, K)`` (e.g. the ``2l+1`` SH components
    of one band): the ``K`` images side by side, each on :func:`diverging8` scaled by the
    largest magnitude of all ``K`` (so their sizes compare), 8-bit ``(H, K(W+2)+2, 3)``."""
    c = np.asarray(components, dtype=np.float64)
    h, w, k = c.shape
    scale = max(float(np.abs(c).max()), 1e-30)
    out = np.full((h + 2 * STRIP_GAP, k * (w + STRIP_GAP) + STRIP_GAP, 3), STRIP_BACKGROUND,
                  np.uint8)  # fmt: skip
    for i in range(k):
        x = STRIP_GAP + i * (w + STRIP_GAP)
        out[STRIP_GAP : STRIP_GAP + h, x : x + w] = diverging8(c[:, :, i] / scale)
    return out
