"""Reading HDR images (EXR, Radiance HDR, anything OpenImageIO reads) as float32."""

import numpy as np
import OpenImageIO as oiio

from shbake import resources
from shbake.errors import ImageReadError

MAX_PIXELS = 1 << 28
"""Refuse images above 268 M pixels (a 16k×16k map is 268 M): a guard against absurd headers."""
MAX_DECODED_BYTES = 2 << 30
"""Refuse images whose decoded float32 pixels exceed 2 GiB (a 16k × 8k RGBA map), whatever
the file size: a zip EXR of one colour compresses ~2000:1."""
WORKING_COPIES = 4
"""float32 RGB copies of the image a command may hold at once (decode, RGB, repair,
conversion), used for the memory estimate."""


def read_image(path: str) -> tuple[np.ndarray, dict]:
    """Read the first subimage of ``path`` as ``(H, W, C)`` float32.

    Returns the pixels and a dict with ``channelnames``, ``format`` (the
    stored pixel type) and ``envmap`` (OpenEXR's ``envmap`` attribute when
    present: ``"latlong"`` or ``"cube"``).

    Raises
    ------
    ImageReadError
        Missing, empty, non-image, truncated or corrupt file.
    """
    if resources.check_regular_file(path, "image").st_size == 0:
        raise ImageReadError(f"{path}: empty file")
    inp = oiio.ImageInput.open(path)
    if inp is None:
        msg = oiio.geterror().strip().splitlines()
        raise ImageReadError(
            f"{path}: not a readable image ({msg[-1] if msg else 'unknown format'})"
        )
    try:
        spec = inp.spec()
        if spec.width <= 0 or spec.height <= 0 or spec.nchannels <= 0:
            raise ImageReadError(f"{path}: image has no pixels")
        pixels_n = spec.width * spec.height
        if pixels_n > MAX_PIXELS:
            raise ImageReadError(f"{path}: {spec.width}x{spec.height} exceeds {MAX_PIXELS} pixels")
        decoded = pixels_n * spec.nchannels * 4
        if decoded > MAX_DECODED_BYTES:
            raise ImageReadError(
                f"{path}: {spec.width}x{spec.height}x{spec.nchannels} decodes to "
                f"{resources.human(decoded)}, above the {resources.human(MAX_DECODED_BYTES)} "
                "an input image may have"
            )
        resources.check_memory(
            decoded + WORKING_COPIES * pixels_n * 3 * 4,
            f"reading {path} ({spec.width}x{spec.height})",
        )
        pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
        err = inp.geterror().strip()
        if pixels is None or err:
            first = err.splitlines()[0] if err else "read failed"
            raise ImageReadError(f"{path}: truncated or corrupt image ({first})")
        envmap = spec.getattribute("envmap")
        meta = {
            "channelnames": tuple(spec.channelnames),
            "format": str(spec.format),
            "display_referred": spec.format.basetype in (oiio.UINT8, oiio.UINT16)
            and spec.getattribute("oiio:ColorSpace") not in ("linear", "Linear", "lin_rec709"),
            "envmap": {0: "latlong", 1: "cube"}.get(envmap, None) if envmap is not None else None,
        }
    finally:
        inp.close()
    pixels = np.asarray(pixels, dtype=np.float32)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    return pixels, meta


def to_rgb(pixels: np.ndarray, channelnames: tuple[str, ...]) -> tuple[np.ndarray, str]:
    """Reduce RGB / RGBA / single-channel (and luminance-alpha) pixels to RGB.

    Returns ``(rgb, note)`` where ``note`` says what was done. Single-channel
    maps are replicated to grey RGB; alpha is dropped; with more channels,
    the ones named R, G, B are used.
    """
    names = [n.split(".")[-1].upper() for n in channelnames]
    nc = pixels.shape[2]
    if nc == 1 or (nc == 2 and names[1] == "A"):
        return np.repeat(pixels[:, :, :1], 3, axis=2), "single channel replicated to RGB"
    if all(c in names for c in "RGB"):
        idx = [names.index(c) for c in "RGB"]
        note = "RGB" if nc == 3 else f"RGB taken from channels {','.join(channelnames)}"
        if idx == [0, 1, 2] and nc == 3:
            return np.ascontiguousarray(pixels), note  # already RGB: no copy
        return np.ascontiguousarray(pixels[:, :, idx]), note
    if nc >= 3:
        return np.ascontiguousarray(pixels[:, :, :3]), f"first 3 of {nc} channels used as RGB"
    raise ImageReadError(f"cannot interpret channels {channelnames} as RGB")


def sha256_of(path: str) -> str:
    """Hex SHA-256 of a file's bytes (bounded by its size; special files refused)."""
    return resources.sha256_of(path)
