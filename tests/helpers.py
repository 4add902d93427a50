"""Helpers shared by the tests and the benchmarks: the shared maps, synthetic maps, EXR writing.

Imported as ``tests.helpers`` everywhere (``pythonpath = ["."]`` in pyproject.toml, so
``pytest`` and ``python -m pytest`` collect the same set). Fixtures live in ``conftest.py``.
"""

import contextlib
import logging
import os
from pathlib import Path

import numpy as np
from numpy.polynomial.legendre import leggauss

from shbake.envmap.layouts import latlong_directions
from shbake.sh.basis import real_sh

ROOT = Path(__file__).resolve().parent.parent
SHARED_HDRI = ROOT.parent / "shared" / "hdri"
SAMPLES = ROOT / "data_samples"
SHARED_MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
GOLDEN = ROOT / "tests" / "data" / "golden"
"""Golden files: outputs of the release before a change, compared byte for byte
(``tests/test_golden.py``; rewritten only by ``pytest --update-golden``)."""


def map_path(name: str) -> Path:
    """A shared map; the copies in data_samples/ stand in when ../shared is absent."""
    p = SHARED_HDRI / f"{name}.exr"
    if p.exists():
        return p
    p = SAMPLES / f"{name}.exr"
    if not p.exists():
        raise FileNotFoundError(f"map {name} is in neither {SHARED_HDRI} nor {SAMPLES}")
    return p


def synth_latlong(coeffs: np.ndarray, height: int) -> np.ndarray:
    """A lat-long image (H, 2H, C) whose pixels are Σ c_i y_i at the cell centres."""
    lmax = int(round(np.sqrt(coeffs.shape[0]))) - 1
    d = latlong_directions(height, 2 * height)
    return (real_sh(d, lmax) @ coeffs).astype(np.float64)


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


def gauss_legendre_sphere(lmax):
    """Product rule exact for band ≤ 2 lmax: Gauss–Legendre in z, uniform in φ."""
    z, wz = leggauss(lmax + 1)
    nphi = 2 * lmax + 2
    phi = 2 * np.pi * np.arange(nphi) / nphi
    r = np.sqrt(1 - z * z)
    d = np.stack(
        [np.outer(r, np.cos(phi)), np.outer(r, np.sin(phi)), np.repeat(z[:, None], nphi, 1)], -1
    )
    w = np.outer(wz, np.full(nphi, 2 * np.pi / nphi))
    return d.reshape(-1, 3), w.ravel()


def write_merl(path, values: np.ndarray) -> None:
    """Write ``(3, 90, 90, 180)`` BRDF values (1/sr) as a MERL ``.binary`` file (test-only
    writer, independent of shbake's reader): int32 dims 90, 90, 180, then float64 values
    divided by the MERL channel scales 1/1500, 1.15/1500, 1.66/1500."""
    v = np.asarray(values, dtype=float)
    scales = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])
    with open(os.fspath(path), "wb") as f:
        f.write(np.array([90, 90, 180], dtype="<i4").tobytes())
        f.write((v / scales[:, None, None, None]).astype("<f8").tobytes())


@contextlib.contextmanager
def local_cluster():
    """A 2-worker Dask cluster on 127.0.0.1 (processes, one thread each, logs silenced);
    yields its scheduler address."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0", silence_logs=logging.CRITICAL) as c:  # fmt: skip
        yield c.scheduler_address
