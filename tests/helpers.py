"""Helpers shared by the tests and the benchmarks: the shared maps, synthetic maps, EXR writing.

Imported as ``tests.helpers`` everywhere (``pythonpath = ["."]`` in pyproject.toml, so
``pytest`` and ``python -m pytest`` collect the same set). Fixtures live in ``conftest.py``.
"""

import contextlib
import json
import logging
import os
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss

from shbake.envmap.layouts import latlong_directions
from shbake.sh.basis import real_sh

ROOT = Path(__file__).resolve().parent.parent
SHARED_HDRI = ROOT.parent / "shared" / "hdri"
SAMPLES = ROOT / "data_samples"
ENGINES_DIR = str(ROOT / "tests" / "engines")
"""The pinned engine packages (three, Babylon.js, Filament) and their node scripts."""
SHARED_MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
GOLDEN = ROOT / "tests" / "data" / "golden"
GOLDEN_LANES = 16
"""The vector width (:data:`shbake.simd.LANES`: 16 with AVX-512, 4 otherwise) the golden
files were written with. An output whose bytes depend on the width (the lanes' summation
order: ~1e-16 relative) has a second golden file, for width ``n``, in
``GOLDEN/lanes-n/`` (:func:`golden_file`)."""


def golden_file(name: str, lanes: int) -> Path:
    """The golden file of output ``name`` on a CPU of vector width ``lanes``: the width's
    own file where its bytes differ (``GOLDEN/lanes-{lanes}/name``), else the main one."""
    own = GOLDEN / f"lanes-{lanes}" / name
    return own if lanes != GOLDEN_LANES and own.exists() else GOLDEN / name
DIFFUSE_SCENE = """[scene]
out_dir = "out"
[[environments]]
map = "maps/*.exr"
[[materials]]
name = "plaster"
kind = "diffuse"
"""
"""A scene of one diffuse material on every map of its ``maps`` folder."""
"""Golden files: outputs of the release before a change, compared byte for byte
(``tests/system/test_golden.py``; rewritten only by ``pytest --update-golden``)."""


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


def repeat_first_light(src, dst, count: int) -> None:
    """Copy the env_sh asset ``src`` to ``dst`` with its first light (direction, irradiance,
    angular radius) repeated ``count`` times: a valid asset (the format has no light limit)
    with more lights than a shader may hold."""
    import shutil

    import h5py

    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        for name in ("direction", "irradiance", "angular_radius"):
            data, attrs = f[f"/lights/{name}"][()], dict(f[f"/lights/{name}"].attrs)
            del f[f"/lights/{name}"]
            f[f"/lights/{name}"] = np.repeat(data[:1], count, axis=0)
            f[f"/lights/{name}"].attrs.update(attrs)


@contextlib.contextmanager
def local_cluster():
    """A 2-worker Dask cluster on 127.0.0.1 (processes, one thread each, logs silenced);
    yields its scheduler address."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0", silence_logs=logging.CRITICAL) as c:  # fmt: skip
        yield c.scheduler_address


def smooth_map(h=32, sun=None):
    """A smooth positive lat-long map (optionally a one-texel sun)."""
    d = latlong_directions(h, 2 * h)
    base = 0.5 + 0.4 * d[..., 1] + 0.3 * d[..., 2] ** 2
    img = np.stack([base, 0.8 * base + 0.1 * d[..., 0], 1.2 - 0.5 * base], -1)
    img = np.clip(img, 0.02, None).astype(np.float32)
    if sun is not None:
        img[h // 4, h // 2] = sun
    return img


def run_node(script: str, *args: str) -> dict:
    """Run the node script ``tests/engines/SCRIPT ARGS`` (the engines' own code); the JSON of
    its last output line."""
    if not os.path.isdir(os.path.join(ENGINES_DIR, "node_modules")):
        pytest.fail("engine packages missing: run `npm ci --prefix tests/engines` (make test does)")
    r = subprocess.run(
        ["node", os.path.join(ENGINES_DIR, script), *args],
        cwd=ENGINES_DIR,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def ktx2_levels(path) -> list[np.ndarray]:
    """Every level of a KTX2 file of half or single floats (``vkFormat`` 83 RG16F, 97 RGBA16F, 103
    RG32F, 109 RGBA32F) as float32 (KTX 2.0 §3.9 level index; an independent reader of the
    bytes, not shbake's writer)."""
    data = open(path, "rb").read()
    vk_format = struct.unpack_from("<I", data, 12)[0]
    dtype = {83: "<f2", 97: "<f2", 103: "<f4", 109: "<f4"}[vk_format]
    n_levels = struct.unpack_from("<I", data, 12 + 4 * 7)[0]
    out = []
    for i in range(n_levels):
        off, length, _ = struct.unpack_from("<3Q", data, 80 + 24 * i)
        out.append(np.frombuffer(data[off : off + length], dtype).astype(np.float32))
    return out


RNG = np.random.default_rng(3)
"""The stream :func:`hemi` draws from when given none (shared: draws depend on test order)."""


def hemi(n, rng=RNG):
    """``n`` random unit directions of the upper hemisphere (``z ≥ 1e-3`` before normalising)."""
    d = rng.normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2]) + 1e-3
    return d / np.linalg.norm(d, axis=1, keepdims=True)
