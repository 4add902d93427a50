"""Shared fixtures: the plan cache, the CLI runner, random coefficients (see helpers.py)."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the shbake command does (cli/__init__.py)

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from shbake_cli.main import main  # noqa: E402


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


@pytest.fixture(scope="session")
def engine_browser(tmp_path_factory):
    """One headless Chromium for the session's rendered engine tests (``engine_browser.py``),
    serving files under the session's temporary folder. Without Chromium the tests skip with
    the reason, except as root or in CI, where ``make test`` installs it: there they fail."""
    from engine_browser import EngineBrowser, chromium_or_reason

    reason = chromium_or_reason()
    if reason is not None:
        if os.geteuid() == 0 or os.environ.get("CI"):
            pytest.fail(f"rendered engine tests cannot run: {reason}")
        pytest.skip(reason)
    browser = EngineBrowser(str(tmp_path_factory.getbasetemp()))
    yield browser
    browser.close()


@pytest.fixture
def random_coeffs():
    def make(lmax, channels=3, seed=0):
        rng = np.random.default_rng(seed)
        return rng.normal(size=((lmax + 1) ** 2, channels))

    return make
