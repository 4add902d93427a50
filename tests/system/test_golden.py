"""Every asset, export and preview image byte-identical to the release before a change.

The golden files in ``tests/data/golden/`` were written by the commit before the second
shape pass (issue 28) from one small map, ``esplanade-64x32.exr`` (the shared esplanade
map, 8×8 box-averaged: negative pixels and a sun kept), at small sizes so the whole bake
takes seconds once numba's cache is warm. They change only through
``pytest --update-golden`` (tests/conftest.py), on purpose, in a commit that says why.

They were written on a CPU with AVX-512 (:data:`~tests.helpers.GOLDEN_LANES`). Where an
output's bytes depend on the vector width (the SH projection's lanes sum in another
order), ``lanes-4/`` holds the file an AVX2 CPU writes, checked to differ from the main
one only by rounding (:func:`test_width_golden_differs_only_in_rounding`).
"""

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from shbake_cli.main import main

from tests.helpers import GOLDEN, GOLDEN_LANES

pytestmark = pytest.mark.xdist_group("golden")  # one worker runs the commands once

MAP = "esplanade-64x32.exr"
FACES = tuple(f"_{i}_{f}" for i in range(2) for f in range(6))
COMMANDS = (
    ("project-env", MAP, "-o", "env.h5", "--lmax", "8", "--extract-sun", "--exr-dir",
     "envmaps", "--size", "16"),
    ("brdf-table", "ggx", "-p", "alpha=0.3", "--lmax", "4", "--size", "16", "--samples", "64",
     "--reproducible", "-o", "table.h5"),
    ("probe-fit", MAP, "-o", "shexp.h5", "--normals", "64", "--views", "8", "--alpha-count",
     "4", "--samples", "256"),
    ("split-sum", MAP, "-o", "split.h5", "--size", "16", "--min-size", "8", "--samples", "64"),
    ("shrm", MAP, "-o", "shrm.h5", "--brdf", "ggx", "-p", "alpha=0.3", "--F", "6", "--P", "2",
     "--face-size", "8"),
    *(("export", "env.h5", "--to", to, "--out-dir", f"ex-{to}", "--size", "16", "--floor", "8",
       "--samples", "16") for to in ("gltf", "babylon", "ktx2", "filament")),
    *(("export", "env.h5", "--to", to, "--out-dir", f"ex-{to}") for to in ("threejs", "unity")),
    ("export", "split.h5", "--to", "ktx2", "--out-dir", "ex-split", "--size", "16", "--floor",
     "8", "--samples", "16"),
    *(("preview", "env.h5", "--pass", p, "--size", "16", "-o", f"pv-{p}.exr")
      for p in ("irradiance", "tangent")),
    ("preview", "env.h5", "--pass", "kautz", "--table", "table.h5", "--size", "16", "-o",
     "pv-kautz.exr"),
    ("preview", "shexp.h5", "--size", "16", "--roughness", "0.6", "--f0", "0.04", "-o",
     "pv-shexp.exr"),
    ("preview", "split.h5", "--size", "16", "--roughness", "0.6", "-o", "pv-split.exr"),
    ("preview", "shrm.h5", "--size", "16", "-o", "pv-shrm.exr"),
)  # fmt: skip
"""The commands, run in one folder in this order."""
OUTPUTS = (
    "env.h5", "envmaps/irradiance.exr", "envmaps/tangent_irradiance.exr", "table.h5",
    "shexp.h5", "split.h5", "shrm.h5",
    *(f"ex-{t}/env.gltf" for t in ("gltf", "babylon")),
    *(f"ex-{t}/env_specular{f}.png" for t in ("gltf", "babylon") for f in FACES),
    "ex-ktx2/env.ktx2", "ex-ktx2/env_dfg.ktx2", "ex-ktx2/env_dfg.exr",
    "ex-filament/env_ibl.ktx", "ex-filament/env_skybox.ktx", "ex-filament/env_sh.txt",
    "ex-filament/env_sun.json", "ex-threejs/env.json", "ex-unity/env.unity.json",
    "ex-split/split.ktx2", "ex-split/split_dfg.ktx2", "ex-split/split_dfg.exr",
    *(f"pv-{p}.exr" for p in ("irradiance", "tangent", "kautz", "shexp", "split", "shrm")),
)  # fmt: skip
"""Every file the commands write, but the contact sheets (their titles carry timings)."""


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    """The folder the :data:`COMMANDS` ran in."""
    folder = tmp_path_factory.mktemp("golden")
    shutil.copyfile(GOLDEN / MAP, folder / MAP)
    here = os.getcwd()
    os.chdir(folder)
    try:
        for argv in COMMANDS:
            assert main([*argv, "--quiet"]) == 0, argv
    finally:
        os.chdir(here)
    return folder


def test_outputs_listed(baked):
    """The golden list names every file the commands write (so none escapes the check)."""
    written = {
        str(p.relative_to(baked))
        for p in baked.rglob("*")
        if p.is_file() and p.name != MAP and not p.name.endswith("-sheet.png")
    }
    assert written == set(OUTPUTS)


@pytest.mark.parametrize("name", OUTPUTS)
def test_byte_identical(baked, golden, name):
    golden(name, baked / name)


ROUNDING = {"f": 1e-12, "e": 1e-6}
"""Largest difference, relative to the largest magnitude of its array, a width's golden
file may have from the main one: float64 (``"f"``, a few thousand units in the last place:
the fits carry the summation order's 1e-16 on; measured up to 1e-14) and float32 images
(a few units; measured: one)."""


def _close(a, b, what: str) -> None:
    """``a`` and ``b`` equal but for rounding: the same structure, strings and integers,
    floats within :data:`ROUNDING` of their array's largest magnitude."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), what
        for key in a:
            _close(a[key], b[key], f"{what}/{key}")
        return
    if isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), what
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _close(x, y, f"{what}[{i}]")
        return
    if isinstance(a, (str, bytes)):
        try:
            _close(json.loads(a), json.loads(b), what)
        except ValueError:
            assert a == b, what
        return
    a, b = np.asarray(a), np.asarray(b)
    assert (a.dtype, a.shape) == (b.dtype, b.shape), what
    if a.dtype.kind != "f":
        assert np.array_equal(a, b), what
        return
    scale = max(float(np.max(np.abs(a), initial=0.0)), np.finfo(a.dtype).tiny)
    worst = float(np.max(np.abs(a - b), initial=0.0)) / scale
    assert worst <= ROUNDING["f" if a.dtype.itemsize == 8 else "e"], f"{what}: {worst:.3g}"


def _tree(path: Path):
    """An asset's groups, datasets and attributes (HDF5) or an image's header and pixels
    (EXR), as nested dicts and arrays."""
    if path.suffix == ".exr":
        import OpenImageIO as oiio

        image = oiio.ImageInput.open(str(path))
        try:
            spec = image.spec()
            header = {a.name: str(a.value) for a in spec.extra_attribs}
            return {"header": header, "pixels": image.read_image()}
        finally:
            image.close()
    import h5py

    def walk(node):
        out = {"@" + k: v.decode() if isinstance(v, bytes) else v for k, v in node.attrs.items()}
        if isinstance(node, h5py.Dataset):
            out["data"] = node[()]
        else:
            out.update({k: walk(node[k]) for k in node})
        return out

    with h5py.File(path, "r") as f:
        return walk(f)


WIDTH_FILES = sorted(p for p in GOLDEN.glob("lanes-*/**/*") if p.is_file())
"""The golden files of vector widths other than :data:`~tests.helpers.GOLDEN_LANES`."""


@pytest.mark.parametrize("path", WIDTH_FILES, ids=lambda p: str(p.relative_to(GOLDEN)))
def test_width_golden_differs_only_in_rounding(path):
    """A width's own golden file (:func:`tests.helpers.golden_file`) is that of a listed
    output and differs from the main one only by the lanes' summation order: the same
    groups, attributes and strings, floats within :data:`ROUNDING` of their array's
    largest magnitude (so it cannot hide a change the main files would catch)."""
    width, *name = path.relative_to(GOLDEN).parts
    main = GOLDEN.joinpath(*name)
    assert "/".join(name) in OUTPUTS and width != f"lanes-{GOLDEN_LANES}"
    assert path.read_bytes() != main.read_bytes()
    _close(_tree(path), _tree(main), path.name)
