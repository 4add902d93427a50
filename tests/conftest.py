"""Shared fixtures: the plan cache, the CLI runner, random coefficients, golden files (see
helpers.py), the small maps of the probe tests, the sunny asset of the export tests, a white dome;
the ``--update-golden`` option. Fixtures one folder alone uses sit in that folder's conftest.py."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the shbake command does (cli/__init__.py)
# The make runs of the scene tests behave as when a user types make: not as sub-makes of the
# `make test` that runs pytest (MAKELEVEL adds "Entering directory" lines, MAKEFLAGS its
# jobserver and options).
for outer_make in ("MAKELEVEL", "MAKEFLAGS", "MFLAGS", "MAKEOVERRIDES"):
    os.environ.pop(outer_make, None)

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from shbake_cli.main import main  # noqa: E402

from shbake.bakers.env_sh import bake_env_sh  # noqa: E402
from shbake.envmap import load_environment  # noqa: E402
from shbake.format.asset import write_asset  # noqa: E402
from shbake.format.images import write_exr  # noqa: E402
from tests.export_checks import SHARED  # noqa: E402
from tests.helpers import GOLDEN, GOLDEN_LANES, golden_file, smooth_map, write_test_exr  # noqa: E402


@pytest.fixture(scope="session", autouse=True)
def plan_cache(tmp_path_factory):
    """Keep shbake's plan cache (SHBAKE_CACHE_DIR) inside the test session: one folder for
    both xdist workers, as for the ``shbake`` processes of a ``make -j`` (each worker built
    the same quadrature plans and measured the same recipe costs)."""
    base = tmp_path_factory.getbasetemp()
    folder = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "plan-cache"
    folder.mkdir(exist_ok=True)
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


@pytest.fixture(scope="session")
def engine_browser(tmp_path_factory):
    """One headless Chromium for the session's rendered engine tests (``engine_browser.py``),
    serving files under the session's temporary folder. Without Chromium the tests skip with
    the reason, except as root or in CI, where ``make test`` installs it: there they fail."""
    from tests.engine_browser import EngineBrowser, chromium_or_reason

    reason = chromium_or_reason()
    if reason is not None:
        if os.geteuid() == 0 or os.environ.get("CI"):
            pytest.fail(f"rendered engine tests cannot run: {reason}")
        pytest.skip(reason)
    browser = EngineBrowser(str(tmp_path_factory.getbasetemp()))
    yield browser
    browser.close()


@pytest.fixture(scope="module")
def probe_maps(tmp_path_factory):
    """Four small smooth maps (32 × 64 EXR, scaled 1 … 4), for the probe commands."""
    d = tmp_path_factory.mktemp("maps")
    paths = []
    for i in range(4):
        path = d / f"m{i}.exr"
        write_exr(str(path), smooth_map(32) * (1 + i))
        paths.append(str(path))
    return paths


@pytest.fixture(scope="session")
def sky_asset(tmp_path_factory):
    """The esplanade map baked to SH (lmax 2) with its sun extracted: what the export tests
    export (format/exports, batch/test_export.py; baked once, as when they were one file)."""
    d = tmp_path_factory.mktemp("eng")
    path = os.path.join(SHARED, "hdri", "esplanade.exr")
    env = load_environment(path, quiet=True)
    asset, _ = bake_env_sh(
        env, lmax=2, sun=True, provenance={"input_abspath": os.path.abspath(path)}
    )
    h5 = str(d / "s.h5")
    write_asset(h5, asset)
    return {"h5": h5, "dir": d, "env": env}


@pytest.fixture
def dome_asset(run_cli, tmp_path):
    """A white dome (1 everywhere, 32 × 64) baked by ``project-env``: shades to the albedo."""
    src = write_test_exr(tmp_path / "dome.exr", np.ones((32, 64, 3)))
    assert run_cli("project-env", src, "-o", tmp_path / "dome.h5", "-q")[0] == 0
    return tmp_path / "dome.h5"


@pytest.fixture
def random_coeffs():
    def make(lmax, channels=3, seed=0):
        rng = np.random.default_rng(seed)
        return rng.normal(size=((lmax + 1) ** 2, channels))

    return make


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items):
    """Tests marked ``heavy`` first, the others in their order. ``--dist loadgroup`` hands
    out the xdist groups, then the other tests in collection order: the README examples
    (87 s, collected near the end) ran alone on one worker while the other had finished."""
    items.sort(key=lambda item: item.get_closest_marker("heavy") is None)


def pytest_addoption(parser):
    parser.addoption(
        "--update-golden",
        action="store_true",
        default=False,
        help="rewrite the golden files under tests/data/golden/ from this checkout's outputs "
        "instead of comparing with them (review and commit the difference on purpose)",
    )


@pytest.fixture
def golden(request):
    """``check(name, path)``: the bytes of ``path`` must equal its golden file
    (:func:`tests.helpers.golden_file`: ``tests/data/golden/NAME``, or the CPU's vector
    width's own file); with ``pytest --update-golden`` the golden file is written instead
    (the only way one changes, as Filament's cmgen tests do): the main one on a CPU of
    :data:`~tests.helpers.GOLDEN_LANES`, else the width's own, only where it differs."""
    from shbake.simd import LANES

    update = request.config.getoption("--update-golden")

    def check(name: str, path) -> None:
        want = golden_file(name, LANES)
        got = Path(path).read_bytes()
        if update:
            own = GOLDEN / f"lanes-{LANES}" / name
            if LANES == GOLDEN_LANES or got != (GOLDEN / name).read_bytes():
                want = GOLDEN / name if LANES == GOLDEN_LANES else own
                want.parent.mkdir(parents=True, exist_ok=True)
                want.write_bytes(got)
            else:
                own.unlink(missing_ok=True)
            return
        assert want.exists(), f"no golden file {want}; make it with pytest --update-golden"
        assert got == want.read_bytes(), (
            f"{path} differs from the golden file {want} ({len(got)} vs "
            f"{want.stat().st_size} bytes); if the change is meant, pytest --update-golden"
        )

    return check
