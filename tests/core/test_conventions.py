"""Storing values as float32 (:func:`shbake.conventions.to_float32`): what a plain cast
stores as ±inf with numpy's "overflow encountered in cast" is refused in one line naming the
input and the step; everything float32 holds is cast exactly as ``astype`` casts it."""

import warnings

import numpy as np
import pytest

from shbake.conventions import FLOAT32_MAX, to_float32
from shbake.errors import InputError


def test_values_float32_holds_are_cast_as_astype():
    top = np.nextafter(np.float64(FLOAT32_MAX), np.inf)  # rounds to the largest float32
    a = np.array([0.0, -1.5, 1e-45, 3e38, -FLOAT32_MAX, top, np.nan, np.inf, -np.inf])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = to_float32(a, "m.exr", "x")
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, a.astype(np.float32))


@pytest.mark.parametrize("value", [1e39, -3.5e38, 1e300])
def test_overflow_is_one_line_naming_input_and_step(value):
    a = np.full((2, 3), 1.0)
    a[1, 2] = value
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "overflow encountered in cast"
        with pytest.raises(InputError) as e:
            to_float32(a, "sky.exr", "the SHRM projection")
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith("sky.exr: values too large to store in float32 after the SHRM "
                          f"projection (largest {abs(value):.4g}; float32 holds at most ")
