"""End-to-end ``project-env`` time (EXR decode included) and preview frames per second.

Runs the installed CLI in fresh processes (numba's on-disk cache warm), so the
figures are what a build pipeline sees per map. Best of 3.

    .venv/bin/python bench/end_to_end.py
"""

import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHBAKE = str(ROOT / ".venv" / "bin" / "shbake")
MAP = ROOT / "data_samples" / "esplanade.exr"


def timed(args, n=3):
    best = float("inf")
    out = ""
    for _ in range(n):
        t0 = time.perf_counter()
        out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    with tempfile.TemporaryDirectory() as tmp:
        asset = os.path.join(tmp, "e.h5")
        print("| command | best of 3, s |")
        print("|---|---|")
        for extra in (
            [],
            ["--extract-sun"],
            ["--lmax", "8", "--extract-sun", "--window", "dering"],
        ):
            args = [SHBAKE, "project-env", str(MAP), "-o", asset, "-q", *extra]
            t, _ = timed(args)
            print(f"| `shbake project-env esplanade.exr {' '.join(extra)}` | {t:.3f} |")
        for p in ("irradiance", "tangent"):
            _, out = timed(
                [
                    SHBAKE,
                    "preview",
                    asset,
                    "--pass",
                    p,
                    "-o",
                    os.path.join(tmp, "p.exr"),
                    "--size",
                    "512",
                    "--json",
                ],
                n=1,
            )
            s = json.loads(out)
            print(
                f"| preview `{p}` pass 512×512, kernel only | {s['seconds']:.5f} "
                f"({s['fps']:.0f} frames/s) |"
            )


if __name__ == "__main__":
    main()
