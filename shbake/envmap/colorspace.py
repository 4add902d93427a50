"""Conversion of input RGB to shbake's working space, linear Rec.709 (colour-science)."""

import warnings

import numpy as np

from shbake.conventions import to_float32
from shbake.errors import ParameterError

WORKING_SPACE = "ITU-R BT.709"


def _colour():
    # Imported on demand: colour-science is slow to import and warns that
    # matplotlib is absent, which shbake does not need.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
    return colour


DISPLAY_SRGB = ("sRGB-display", "srgb-display")
"""Names declaring display-referred sRGB pixels (8-bit PNG/JPEG): the sRGB transfer function
is decoded (IEC 61966-2-1), primaries are Rec.709."""


def to_working_space(pixels: np.ndarray, name: str, path: str = "the map") -> np.ndarray:
    """Convert *linear* RGB in colourspace ``name`` to linear Rec.709 (CAT02 adaptation).

    The input is taken as scene-linear (no transfer function is decoded):
    HDR maps are stored linear. ``sRGB-display`` (:data:`DISPLAY_SRGB`) instead decodes
    the sRGB transfer function of display-referred 8-bit images. A texel whose converted
    value float32 cannot hold (a saturated colour near the float32 limit: a wider gamut's
    primary is more than 1 in Rec.709, ACEScg's red 1.71) is refused in one line naming the map
    ``path`` (:func:`~shbake.conventions.to_float32`), before any work reads the pixels.
    """
    if name in DISPLAY_SRGB:
        x = np.asarray(pixels, dtype=np.float64)
        lin = np.where(x <= 0.04045, x / 12.92, ((np.maximum(x, 0.04045) + 0.055) / 1.055) ** 2.4)
        return to_float32(lin, path, f"the colour conversion from {name} to linear Rec.709")
    if name in (WORKING_SPACE, "Rec.709", "sRGB", "linear-rec709"):
        return pixels
    colour = _colour()
    try:
        src = colour.RGB_COLOURSPACES[name]
    except KeyError:
        raise ParameterError(
            f"unknown colourspace {name!r}; e.g. ACEScg, ACES2065-1, ITU-R BT.2020, Display P3"
        ) from None
    dst = colour.RGB_COLOURSPACES[WORKING_SPACE]
    out = colour.RGB_to_RGB(
        pixels.astype(np.float64), src, dst, chromatic_adaptation_transform="CAT02"
    )
    return to_float32(out, path, f"the colour conversion from {name} to linear Rec.709")
