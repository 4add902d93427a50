"""Batches (issue 11, item 12) and the issue's minor items: a bad map fails the batch without
half-written probes.
"""

import contextlib
import json
import os
import shutil

import numpy as np

from tests.faults import assert_failed, unchanged


class TestBatches:
    """Item 12: a bad map fails the batch (exit 1) without half-written probes; empty set or
    markdown paths are refused (covered in TestOutputLocations)."""

    def test_bad_map_in_batch(self, run_cli, box):
        (box / "bad.exr").write_bytes(b"not an image")
        with unchanged(box):
            assert_failed(run_cli("probe-fit", box / "bad.exr", box / "map.exr", "--out-dir",
                                  box, "--samples", 64))  # fmt: skip

    def test_completed_probes_stay_valid(self, run_cli, box):
        """Per-probe atomic files: the probe fitted before the bad map is complete and valid;
        nothing half-written is left."""
        from shbake.batch.probe_jobs import GATHER_BATCH
        from shbake.format.asset import read_asset

        # one gather pass of good maps, then the bad one in the next pass
        good = []
        for i in range(GATHER_BATCH):
            shutil.copy(box / "map.exr", box / f"m{i}.exr")
            good.append(box / f"m{i}.exr")
        (box / "zbad.exr").write_bytes(b"not an image")
        before = set(os.listdir(box))
        assert_failed(run_cli("probe-fit", *good, box / "zbad.exr", "--out-dir",
                              box / "probes", "--samples", 64))  # fmt: skip
        assert set(os.listdir(box)) == before | {"probes"}
        assert sorted(os.listdir(box / "probes")) == sorted(f"m{i}.h5" for i in range(len(good)))
        for i in range(len(good)):
            assert read_asset(str(box / "probes" / f"m{i}.h5")).kind == "shexp_probe"

    def test_manifest_lists_what_succeeded(self, run_cli, box):
        """``--manifest``: written even when the batch fails; the probes of the completed
        gather pass are ``written`` with their SHA-256, the rest ``not written``."""
        import hashlib
        import json

        from shbake.batch.probe_jobs import GATHER_BATCH

        good = []
        for i in range(GATHER_BATCH):
            shutil.copy(box / "map.exr", box / f"m{i}.exr")
            good.append(box / f"m{i}.exr")
        (box / "zbad.exr").write_bytes(b"not an image")
        manifest = box / "manifest.json"
        assert_failed(run_cli("probe-fit", *good, box / "zbad.exr", "--out-dir", box / "probes",
                              "--samples", 64, "--manifest", manifest))  # fmt: skip
        doc = json.loads(manifest.read_text())
        assert doc["status"].startswith("failed:")
        rows = {os.path.basename(r["source"]): r for r in doc["probes"]}
        assert rows["zbad.exr"]["status"] == "not written"
        for i in range(len(good)):
            row = rows[f"m{i}.exr"]
            assert row["status"] == "written"
            digest = hashlib.sha256((box / "probes" / f"m{i}.h5").read_bytes()).hexdigest()
            assert row["sha256"] == digest

    def test_manifest_of_a_set_hashes_the_set_written(self, run_cli, box):
        """``-o SET --manifest M``: a new set is written and ``M`` holds the SHA-256 of the
        set this run wrote, not of the file it replaced."""
        import hashlib

        (box / "old.h5").write_bytes(b"junk")
        for name in ("new.h5", "old.h5"):
            manifest = box / f"{name}.json"
            assert run_cli("probe-fit", box / "map.exr", "-o", box / name, "--samples", 64,
                           "--manifest", manifest)[0] == 0  # fmt: skip
            doc = json.loads(manifest.read_text())
            digest = hashlib.sha256((box / name).read_bytes()).hexdigest()
            assert doc["status"] == "ok" and doc["probes"][0]["sha256"] == digest

    def test_manifest_is_never_a_map_or_an_output(self, run_cli, box):
        """A manifest naming the map (or a link to it), the set or a probe of the run is
        refused before any work: nothing is written, the map is intact."""
        os.symlink(box / "map.exr", box / "link.json")
        cases = [("-o", box / "set.h5", box / "map.exr"), ("-o", box / "set.h5", box / "link.json"),
                 ("-o", box / "set.h5", box / "set.h5"), ("--out-dir", box, box / "map.h5")]
        for flag, out, manifest in cases:
            with unchanged(box):
                assert_failed(run_cli("probe-fit", box / "map.exr", flag, out, "--samples", 64,
                                      "--manifest", manifest),  # fmt: skip
                              fragment="--manifest must name another file")

    def test_set_is_all_or_nothing(self, run_cli, box):
        (box / "bad.exr").write_bytes(b"not an image")
        with unchanged(box):
            assert_failed(run_cli("probe-fit", box / "map.exr", box / "bad.exr", "-o",
                                  box / "set.h5", "--samples", 64))  # fmt: skip


# -- minor ------------------------------------------------------------------------------------


class TestMinor:
    """The issue's minor items."""

    def test_8bit_warning_and_colorspace(self, run_cli, box):
        import OpenImageIO as oiio

        img = (np.random.default_rng(0).random((16, 32, 3)) * 255).astype(np.uint8)
        out = oiio.ImageOutput.create(str(box / "ldr.png"))
        out.open(str(box / "ldr.png"), oiio.ImageSpec(32, 16, 3, "uint8"))
        out.write_image(img)
        out.close()
        code, _, err = run_cli("project-env", box / "ldr.png", "-o", box / "a.h5")
        assert code == 0 and "display-referred" in err and "--colorspace" in err
        code, _, err = run_cli("project-env", box / "ldr.png", "-o", box / "b.h5",
                               "--colorspace", "sRGB-display", "--json")  # fmt: skip
        assert code == 0 and "display-referred" not in err

    def test_json_summary_still_one_document(self, run_cli, box):
        code, out, _ = run_cli("project-env", box / "map.exr", "-o", box / "c.h5", "--json")
        assert code == 0
        json.loads(out)

    def test_layout_detection_agrees_with_layout_option(self):
        from shbake.envmap.layouts import LAYOUTS, check_layout, detect_layout
        from shbake.errors import LayoutError

        for h in range(1, 25):
            for w in range(1, 25):
                fitting = []
                for layout in LAYOUTS:
                    with contextlib.suppress(LayoutError):
                        fitting.append(check_layout(layout, h, w))
                try:
                    found = detect_layout(h, w)
                except LayoutError:
                    found = None
                assert (found is None) == (not fitting), (h, w)
                assert found is None or found in fitting, (h, w)

    def test_two_by_one_refused_one_line(self, run_cli, box):
        from tests.helpers import write_test_exr

        write_test_exr(box / "two.exr", np.ones((1, 2, 3)))
        for extra in ([], ["--layout", "latlong"]):
            with unchanged(box):
                assert_failed(run_cli("project-env", box / "two.exr", "-o", box / "t.h5", *extra))
