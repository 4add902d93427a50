"""Whole-process ``shbake project-env`` against a plain OpenImageIO + ducc0 + h5py script.

The map: ``esplanade.exr`` (512×256) upsampled 4× to 2048×1024, written as a
zip-compressed half EXR in a temporary folder (the shared maps are all
512×256). Each run starts a fresh process — imports, EXR decode, validation,
projection, HDF5 write and exit included, numba's on-disk cache as it is (the
small-``lmax`` bake loads neither numba nor scipy). The two commands
alternate, N runs each; the table gives the median and the range of the wall
time and of the CPU time (user + system of the child), and the median of the
per-pair CPU ratios. Threads: the plain script calls ducc0 with
``nthreads=1``; shbake's kernels use ``run_blocks`` (none run here for lmax 8);
``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``.

Bytecode: an installed package runs from compiled ``.pyc`` files (pip compiles
them at install), and so do numpy, h5py and OpenImageIO here; this checkout is
an editable install, so the script compiles ``shbake/`` and ``cli/`` first
(``compileall``) — otherwise, with ``PYTHONDONTWRITEBYTECODE`` set, every run
would compile ~50 shbake modules from source (~60 ms) that no installed copy
compiles. The plain script's own file is compiled on each run in both cases
(a ``__main__`` script is never cached).

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/end_to_end.py [N]
"""

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

ROOT = Path(__file__).resolve().parent.parent
SHBAKE = str(ROOT / ".venv" / "bin" / "shbake")
PYTHON = sys.executable
MAP = ROOT / "data_samples" / "esplanade.exr"


def make_map(path: str, factor: int = 4) -> tuple[int, int]:
    inp = oiio.ImageInput.open(str(MAP))
    px = inp.read_image(0, 0, 0, 3, "float")
    inp.close()
    big = np.repeat(np.repeat(px, factor, axis=0), factor, axis=1)
    spec = oiio.ImageSpec(big.shape[1], big.shape[0], 3, "half")
    spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(path)
    out.open(path, spec)
    out.write_image(big)
    out.close()
    return big.shape[1], big.shape[0]


def run(args) -> tuple[float, float, str]:
    """Wall seconds, CPU seconds (user + sys of the child), stdout."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return wall, cpu, out


def summary(xs) -> str:
    return f"{statistics.median(xs):.3f} ({min(xs):.3f}–{max(xs):.3f})"


def compile_bytecode() -> None:
    """Compile the editable checkout's modules, as a package install does (module doc)."""
    subprocess.run(
        [PYTHON, "-m", "compileall", "-q", str(ROOT / "shbake"), str(ROOT / "cli")],
        check=True,
        capture_output=True,
    )


def main(n: int = 7):
    compile_bytecode()
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "esplanade-2048.exr")
        w, h = make_map(src)
        ours = [SHBAKE, "project-env", src, "-o", os.path.join(tmp, "s.h5"), "-q", "--lmax", "8"]
        plain = [
            PYTHON,
            str(ROOT / "bench" / "plain_project.py"),
            src,
            os.path.join(tmp, "p.h5"),
            "8",
        ]
        run(ours), run(plain)  # warm the page cache and numba's cache
        res = {"shbake": [], "plain": []}
        for _ in range(n):
            res["shbake"].append(run(ours)[:2])
            res["plain"].append(run(plain)[:2])
        ratios = [a[1] / b[1] for a, b in zip(res["shbake"], res["plain"], strict=True)]
        print(f"map {w}×{h} half EXR, lmax 8, {n} alternating runs each, {os.cpu_count()} CPUs")
        print("| process | wall s, median (min–max) | CPU s, median (min–max) |")
        print("|---|---|---|")
        for name, label in (
            ("shbake", "`shbake project-env MAP -o OUT -q --lmax 8`"),
            ("plain", "plain OpenImageIO + ducc0 + h5py script (`bench/plain_project.py`)"),
        ):
            walls = [r[0] for r in res[name]]
            cpus = [r[1] for r in res[name]]
            print(f"| {label} | {summary(walls)} | {summary(cpus)} |")
        print(
            f"\nCPU ratio shbake / plain, per pair: median {statistics.median(ratios):.2f} "
            f"(min {min(ratios):.2f}, max {max(ratios):.2f})"
        )

        # Preview kernels (fps reported by the command itself, kernel only).
        asset = os.path.join(tmp, "s.h5")
        print("\n| preview pass 512×512 | kernel s | frames/s |")
        print("|---|---|---|")
        for p in ("irradiance", "tangent"):
            _, _, out = run(
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
                ]
            )
            s = json.loads(out)
            print(f"| `{p}` | {s['seconds']:.5f} | {s['fps']:.0f} |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
