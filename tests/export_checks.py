"""What the export tests share (format/exports, batch/test_export.py, bakers): the shared maps,
the tolerance of an engine's irradiance against shbake's, and independent readers of what the
engines read (ktx-parse under node; the nine polynomials Filament and Unity sum)."""

import glob
import os
import shutil

import numpy as np
import pytest

from shbake.sh.basis import real_sh
from tests.helpers import run_node

SHARED = os.environ.get(
    "SHBAKE_SHARED", os.path.join(os.path.dirname(__file__), "..", "..", "shared")
)
MAPS = sorted(glob.glob(os.path.join(SHARED, "hdri", "*.exr")))
BAKED_FOR_NODE = [
    pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed"),
    pytest.mark.xdist_group("exports-baked"),  # one worker bakes the 18 assets of `baked`
]
"""The marks of the test modules that read the ``baked`` fixture (format/exports/conftest.py)
with an engine's own code under node."""
N_DIRS = 300
TOL = 1e-4
SMALL = {
    "size": 16,
    "floor": 4,
    "samples": 32,
}  # specular chain kept small: these tests are about SH


def irradiance_scale(src, dirs) -> np.ndarray:
    """Per direction and channel, ``Σ_i |E_i y_i(n)|`` (+ the sun term): the size of what is summed.

    Relative errors are taken against it rather than ``|E(n)|`` alone, which
    nears 0 where the SH terms cancel (three.js's constants have 6 digits,
    e.g. ``0.886227``, so its absolute error is ~1e-6 of the terms).
    """
    s = np.abs(real_sh(dirs, 2)[..., :, None] * src.irradiance9[None]).sum(axis=-2)
    for direction, irradiance in src.lights:
        s = s + np.maximum(dirs @ direction, 0.0)[:, None] * irradiance
    return s


def relative_error(got: np.ndarray, want: np.ndarray, src=None, dirs=None) -> float:
    """Largest per-direction ``‖got − want‖∞ / ‖scale‖∞`` (scale: :func:`irradiance_scale`,
    or ``want``)."""
    num = np.abs(got - want).max(axis=-1)
    ref = irradiance_scale(src, dirs) if src is not None else want
    den = np.maximum(np.abs(ref).max(axis=-1), 1e-12)
    return float((num / den).max())


def read_ktx2(path: str) -> dict:
    """A KTX2 file as ktx-parse (three.js's KTX2 parser) reads it, under node."""
    return run_node("ktx2_read.mjs", path)


def sh9_polynomials(d: np.ndarray) -> np.ndarray:
    """The 9 polynomials Filament's ``irradianceSH`` and Unity's ``SHEvalLinearL0L1/L2`` sum."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    one = np.ones_like(x)
    return np.stack([one, y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y], -1)
