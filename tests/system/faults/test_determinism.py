"""Determinism (issue 11, item 11): every output type is byte-identical across runs."""

import time
from pathlib import Path

import pytest

from tests.faults import snapshot


class TestDeterminism:
    """Item 11: every output type is byte-identical across runs (a second apart: EXR
    ``capDate`` has one-second resolution)."""

    RUNS = {
        "project-env": ["project-env", "{map}", "-o", "{out}/e.h5", "--exr-dir", "{out}/maps",
                        "--png", "--export", "threejs", "--lmax", "4", "-q"],
        "brdf-table": ["brdf-table", "phong", "-o", "{out}/t.h5", "--size", "8", "--lmax", "2",
                       "--samples", "64", "--exr-dir", "{out}/bands", "--reproducible", "-q"],
        "preview": ["preview", "{env}", "-o", "{out}/p.exr", "--size", "8", "--diff", "--png",
                    "-q"],
        "split-sum": ["split-sum", "{map}", "-o", "{out}/s.h5", "--size", "16", "--min-size",
                      "8", "--alphas", "0.25,1", "--samples", "64", "-q"],
    }  # fmt: skip

    @pytest.mark.parametrize("name", list(RUNS))
    def test_identical_bytes(self, run_cli, box, name):
        results = []
        out = box / "out"
        args = [a.format(map=box / "map.exr", env=box / "env.h5", out=out) for a in self.RUNS[name]]
        for i in range(2):  # the same command line (assets record it), a second apart
            out.mkdir()
            code, _, err = run_cli(*args)
            assert code == 0, err
            results.append({str(Path(p).relative_to(out)): b for p, b in snapshot(out).items()})
            out.rename(box / f"run{i}")
            time.sleep(1.1)
        assert results[0].keys() == results[1].keys()
        assert any(k.endswith(".exr") or k.endswith(".h5") for k in results[0])
        differ = [k for k in results[0] if results[0][k] != results[1][k]]
        assert not differ, differ
