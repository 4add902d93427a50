"""Whole-process ``shbake project-env`` against a plain OpenImageIO + ducc0 + h5py script;
frames per second of every ``shbake preview`` pass at 512² against the previous shbake
(the tree before issue 15, unpacked by ``git archive``, its own assets baked by itself).

The map: ``esplanade.exr`` (512×256) upsampled 4× to 2048×1024, written as a
zip-compressed half EXR in a temporary folder (the shared maps are all
512×256). Each run starts a fresh process — imports, EXR decode, validation,
projection, HDF5 write and exit included, numba's on-disk cache as it is (the
small-``lmax`` bake loads neither numba nor scipy). The two commands
alternate, 3 N runs each (one pair's CPU ratio varies by ±25 % on a shared VM:
the median of many pairs is the figure to read); the table gives the median
and the range of the wall time and of the CPU time (user + system of the
child), and the median of the per-pair CPU ratios. Threads: the plain script calls ducc0 with
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

import io
import json
import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from timing import PREVIOUS

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
        pairs = 3 * n
        for _ in range(pairs):
            res["shbake"].append(run(ours)[:2])
            res["plain"].append(run(plain)[:2])
        ratios = [a[1] / b[1] for a, b in zip(res["shbake"], res["plain"], strict=True)]
        print(f"map {w}×{h} half EXR, lmax 8, {pairs} alternating runs each, {os.cpu_count()} CPUs")
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

        # Preview passes (frames per second reported by the command itself, kernel only,
        # and the whole `shbake preview` process).
        preview_table(tmp, os.path.join(tmp, "s.h5"), n)


PREVIEW_SIZE = 512


def previous_cli(tmp: str) -> list[str] | None:
    """The previous shbake (:data:`timing.PREVIOUS`, the tree before issue 15) as a command:
    its ``git archive`` unpacked in ``tmp``, run with the editable install's import hook
    removed so that its own ``shbake`` and ``shbake_cli`` load. ``None`` outside a git
    checkout."""
    root = os.path.join(tmp, "previous")
    try:
        archive = subprocess.run(["git", "archive", PREVIOUS], cwd=ROOT, capture_output=True,
                                 check=True).stdout  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return None
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(root, filter="data")
    os.symlink("cli", os.path.join(root, "shbake_cli"))
    code = (
        "import sys; "
        "sys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in repr(f)]; "
        f"sys.path.insert(0, {root!r}); "
        "from shbake_cli.main import main; main()"
    )
    return [PYTHON, "-c", code]


def preview_assets(cli: list[str], tmp: str, env_asset: str, previous: bool = False) -> dict:
    """Assets for every preview pass, baked by ``cli``: the 2048×1024 bake (env_sh, lmax 8)
    and, from the 512×256 sample map, a Phong BRDF table (lmax 4, the default), an SH-exp
    probe, a split-sum probe and an SHRM (microfacet σ 0.2). The previous shbake names the
    table's size ``--resolution`` and has no ``shrm`` command."""
    small = str(MAP)
    out = {"env": env_asset}
    size = ["--resolution" if previous else "--size", "32"]
    jobs = {
        "table": ["brdf-table", "phong", "-o", os.path.join(tmp, "t.h5"), "--lmax", "4", *size,
                  "--samples", "256", "--reproducible", "-q"],
        "shexp": ["probe-fit", small, "--out-dir", tmp, "-q"],
        "splitsum": ["split-sum", small, "-o", os.path.join(tmp, "ss.h5"), "-q"],
    }  # fmt: skip
    if not previous:
        jobs["shrm"] = ["shrm", small, "-o", os.path.join(tmp, "shrm.h5"), "-p", "sigma=0.2", "-q"]
    for name, args in jobs.items():
        run(cli + args)
        out[name] = (
            args[args.index("-o") + 1] if "-o" in args else os.path.join(tmp, MAP.name[:-4] + ".h5")
        )
    return out


def preview_passes(a: dict) -> list[tuple[str, list[str]]]:
    passes = [
        ("irradiance", [a["env"], "--pass", "irradiance"]),
        ("tangent", [a["env"], "--pass", "tangent"]),
        ("kautz", [a["env"], "--pass", "kautz", "--table", a["table"]]),
        ("shexp (roughness 0.5)", [a["shexp"], "--roughness", "0.5"]),
        ("splitsum (roughness 0.5)", [a["splitsum"], "--roughness", "0.5"]),
    ]
    if "shrm" in a:
        passes.append(("shrm", [a["shrm"]]))
    return passes


def preview_table(tmp: str, env_asset: str, n: int = 7) -> None:
    """Frames per second of every preview pass at 512²: ``n`` processes each of shbake and
    the previous shbake, alternating, after one untimed process each (numba's cache)."""
    exr = os.path.join(tmp, "p.exr")
    common = ["-o", exr, "--size", str(PREVIEW_SIZE), "--json", "-q"]
    ours = preview_passes(preview_assets([SHBAKE], tmp, env_asset))
    prev_cli = previous_cli(tmp)
    prev = {}
    if prev_cli is not None:
        old = os.path.join(tmp, "previous-assets")
        os.mkdir(old)
        prev_env = os.path.join(old, "s.h5")
        run(prev_cli + ["project-env", os.path.join(tmp, "esplanade-2048.exr"), "-o", prev_env,
                        "-q", "--lmax", "8"])  # fmt: skip
        prev = dict(preview_passes(preview_assets(prev_cli, old, prev_env, previous=True)))
    print(
        f"\nPreview passes at {PREVIEW_SIZE}×{PREVIEW_SIZE}: kernel frames/s as reported by "
        f"`shbake preview --json` (the second frame of a process), median (min–max) of {n} "
        f"processes; the previous shbake ({PREVIOUS}, the tree before issue 15) in the same "
        f"loop, alternating, and the per-pair ratio; threads: run_blocks (numba prange in the "
        f"previous) over {os.cpu_count()} CPUs; whole process: wall s of `shbake preview`, "
        f"median:\n"
    )
    print("| pass | frames/s | previous shbake frames/s | ratio | whole process s |")
    print("|---|---|---|---|---|")
    for label, args in ours:
        cmds = {"ours": [SHBAKE, "preview", *args, *common]}
        if label in prev:
            cmds["previous"] = prev_cli + ["preview", *prev[label], *common]
        for cmd in cmds.values():
            run(cmd)  # numba's cache
        fps = {k: {} for k in cmds}
        walls = []
        for _ in range(n):
            for k, cmd in cmds.items():
                wall, _, out = run(cmd)
                s = json.loads(out)
                modes = s.get("modes", {"": s})  # kautz: full, fixed-light, fixed-view
                for mode, m in modes.items():
                    fps[k].setdefault(mode, []).append(m["fps"])
                if k == "ours":
                    walls.append(wall)
        w = statistics.median(walls)
        for mode, xs in fps["ours"].items():
            name = f"kautz {mode.replace('_', '-')}" if mode else label
            old = fps.get("previous", {}).get(mode)
            if old:
                r = [a / b for a, b in zip(xs, old, strict=True)]
                prev_cols = f"{fps_summary(old)} | {ratio_summary(r)}"
            else:
                prev_cols = "– | –"
            print(f"| `{name}` | {fps_summary(xs)} | {prev_cols} | {w:.2f} |")


def fps_summary(xs) -> str:
    return f"{statistics.median(xs):.1f} ({min(xs):.1f}–{max(xs):.1f})"


def ratio_summary(r) -> str:
    return f"{statistics.median(r):.2f} ({min(r):.2f}–{max(r):.2f})"


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
