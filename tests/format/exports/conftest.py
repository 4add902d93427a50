"""Fixtures of the export tests: every shared map baked (plain, sun, fitted lights) and
exported for Babylon.js and three.js, shared by the gltf, threejs and source tests (session
scope: the bakes run once for the folder, as they ran once in the single file before)."""

import json
import os

import pytest

from shbake.bakers.env_sh import bake_env_sh
from shbake.batch.export import export_assets
from shbake.envmap import load_environment
from shbake.format.asset import write_asset
from shbake.sh.windows import fibonacci_sphere
from tests.export_checks import MAPS, N_DIRS, SMALL


@pytest.fixture(scope="module")
def dirs_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("dirs") / "dirs.json"
    p.write_text(json.dumps(fibonacci_sphere(N_DIRS).tolist()))
    return str(p)


@pytest.fixture(
    scope="session",
    params=[(m, s) for m in MAPS for s in ("", "sun", "lights")],
    ids=lambda p: f"{os.path.basename(p[0])[:-4]}{'-' + p[1] if p[1] else ''}",
)
def baked(request, tmp_path_factory):
    """An env_sh asset of a shared map (lmax 2): plain, with the sun extracted or with
    ``--lights auto``; and its exports."""
    path, mode = request.param
    sun = mode == "sun"
    d = tmp_path_factory.mktemp("exp")
    env = load_environment(path, quiet=True)
    asset, _ = bake_env_sh(
        env, lmax=2, sun=sun, lights="auto" if mode == "lights" else None,
        provenance={"input_abspath": os.path.abspath(path)},
    )  # fmt: skip
    h5 = str(d / "a.h5")
    write_asset(h5, asset)
    gltf = export_assets([h5], "gltf", str(d / "a.gltf"), **SMALL)[0]
    three = export_assets([h5], "threejs", str(d / "a.json"))[0]
    name = os.path.basename(path)[:-4] + ("-" + mode if mode else "")
    return {"h5": h5, "gltf": gltf, "three": three, "env": env, "sun": sun, "dir": d, "name": name}
