"""Every asset, export and preview image byte-identical to the release before a change.

The golden files in ``tests/data/golden/`` were written by the commit before the second
shape pass (issue 28) from one small map, ``esplanade-64x32.exr`` (the shared esplanade
map, 8×8 box-averaged: negative pixels and a sun kept), at small sizes so the whole bake
takes seconds once numba's cache is warm. They change only through
``pytest --update-golden`` (tests/conftest.py), on purpose, in a commit that says why.
"""

import os
import shutil

import pytest
from shbake_cli.main import main

from tests.helpers import GOLDEN

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
