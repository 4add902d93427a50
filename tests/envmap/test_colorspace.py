"""Input colourspaces (:func:`shbake.envmap.colorspace.to_working_space`) near the float32
limit: a saturated texel of 3e38 converted from a wider gamut is above 3.4e38 in Rec.709
(ACEScg's red becomes 1.71 red). The conversion stored it as inf after the map's NaN/Inf check
had run, and the bake refused the asset for its non-finite values; it is refused at the
conversion, in one line naming the map."""

import warnings

import numpy as np
import pytest

from shbake.envmap.colorspace import to_working_space
from shbake.errors import InputError


@pytest.mark.parametrize("name", ["ACEScg", "sRGB-display"])
def test_overflow_refused_at_the_conversion(name):
    px = np.ones((2, 4, 3), np.float32)
    px[1, 2] = (3e38, 0.0, 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "overflow encountered in cast"
        with pytest.raises(InputError) as e:
            to_working_space(px, name, "red.exr")
    assert str(e.value).startswith(f"red.exr: values too large to store in float32 after the "
                                   f"colour conversion from {name} to linear Rec.709 ")


def test_a_bright_texel_within_range_converts():
    """1e38 of ACEScg red is 1.7e38 in Rec.709: converted, as the plain cast would."""
    px = np.ones((2, 4, 3), np.float32)
    px[1, 2] = (1e38, 0.0, 0.0)
    out = to_working_space(px, "ACEScg")
    assert out.dtype == np.float32 and np.all(np.isfinite(out))
    assert out[1, 2, 0] == pytest.approx(1.705e38, rel=1e-3)
