"""Shared fixtures: the shared HDR maps, synthetic lat-long maps, the CLI runner."""

import os
from pathlib import Path

import numpy as np
import pytest
from shbake_cli.main import main

from shbake.envmap.layouts import latlong_directions
from shbake.sh.basis import real_sh

ROOT = Path(__file__).resolve().parent.parent
SHARED_HDRI = ROOT.parent / "shared" / "hdri"
SAMPLES = ROOT / "data_samples"
SHARED_MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")


def map_path(name: str) -> Path:
    """A shared map; the copies in data_samples/ stand in when ../shared is absent."""
    p = SHARED_HDRI / f"{name}.exr"
    if p.exists():
        return p
    p = SAMPLES / f"{name}.exr"
    if not p.exists():
        pytest.fail(f"map {name} is in neither {SHARED_HDRI} nor {SAMPLES}")
    return p


def synth_latlong(coeffs: np.ndarray, height: int) -> np.ndarray:
    """A lat-long image (H, 2H, C) whose pixels are Σ c_i y_i at the cell centres."""
    lmax = int(round(np.sqrt(coeffs.shape[0]))) - 1
    d = latlong_directions(height, 2 * height)
    return (real_sh(d, lmax) @ coeffs).astype(np.float64)


@pytest.fixture(scope="session", autouse=True)
def plan_cache(tmp_path_factory):
    """Keep shbake's plan cache (SHBAKE_CACHE_DIR) inside the test session."""
    folder = tmp_path_factory.mktemp("plan-cache")
    os.environ["SHBAKE_CACHE_DIR"] = str(folder)
    return folder


@pytest.fixture
def run_cli(capfd):
    """Run ``shbake ARGS``; return (exit status, stdout, stderr)."""

    def run(*args):
        code = main([str(a) for a in args])
        out, err = capfd.readouterr()
        return code, out, err

    return run


@pytest.fixture
def random_coeffs():
    def make(lmax, channels=3, seed=0):
        rng = np.random.default_rng(seed)
        return rng.normal(size=((lmax + 1) ** 2, channels))

    return make


def write_test_exr(path, pixels, half=False):
    """Write pixels with OpenImageIO directly (not through shbake's writer)."""
    import OpenImageIO as oiio

    pixels = np.asarray(pixels, dtype=np.float32)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(os.fspath(path))
    out.open(os.fspath(path), oiio.ImageSpec(w, h, c, "half" if half else "float"))
    out.write_image(pixels)
    out.close()
    return path
