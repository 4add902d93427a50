"""Fixtures of the BRDF tests: a MERL file tabulating a known analytic model."""

import numpy as np
import pytest

from shbake.brdf import make_brdf
from shbake.brdf.merl import half_diff_grid
from tests.helpers import write_merl


@pytest.fixture(scope="session")
def merl_file(tmp_path_factory):
    """A MERL file tabulating an isotropic GGX (α 0.4, coloured F0); written once."""
    ggx = make_brdf("ggx", F0="0.9,0.5,0.2", alpha=0.4)
    s, v = half_diff_grid()
    vals = ggx.evaluate(s, v)
    vals[(s[..., 2] <= 0) | (v[..., 2] <= 0)] = -1.0  # MERL marks missing data negative
    path = tmp_path_factory.mktemp("merl") / "ggx04.binary"
    write_merl(path, np.moveaxis(vals, -1, 0).clip(0))
    return path, ggx
