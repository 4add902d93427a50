"""Compile shbake's numba kernels into their on-disk cache before the test run.

``make test`` runs this before pytest. From an empty cache (a clean clone) every pytest
worker would otherwise compile the same large kernels at the same time (the BRDF
projection alone takes ~35 s on an idle core), each for itself. Here two processes
compile about half each, one chain of README-style commands on a sample map each; the
workers then load the machine code from ``__pycache__`` (``cache=True``, SPEC §6). On a clean
clone (idle, 2 cores) it took 55 s; a full run after it compiled ~79 s of kernels in all
(numba compile events counted per test), most of them the kautz pass now in the brdf chain.

    .venv/bin/python -m tests.warm_kernels

Nothing it writes is kept (a scratch folder); a failing command fails the warm-up, so a
broken command shows here first, with its own message.
"""

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAP = ROOT / "data_samples" / "forest.exr"

CHAINS = {
    "brdf": [
        "brdf-table ashikhmin-shirley -p nu=24 -p nv=8 --size 8 --tol 1e-2 -o as.h5",
        "shrm sky.exr -o shrm.h5 --brdf microfacet -p sigma=0.2",
        "preview shrm.h5 --pass shrm -o shrm.exr --diff --size 16",
        "project-env sky.exr -o sky.h5 --lmax 4",
        "preview sky.h5 --pass kautz --table as.h5 -o kautz.exr --diff --size 16",
    ],
    "env": [
        "project-env sky.exr -o sky.h5 --lmax 8 --extract-sun --report --export threejs",
        "preview sky.h5 --pass irradiance -o irr.exr --diff --size 32",
        "preview sky.h5 --pass tangent -o tan.exr --diff --size 32",
        "project-env sky.exr -o lights.h5 --lights auto --tol 0.02",
        "split-sum sky.exr -o splitsum.h5",
        "probe-fit sky.exr -o probe.h5",
        "preview probe.h5 --roughness 0.6 --f0 0.04 -o gloss.exr --diff --size 16",
        "probe-eval sky.exr --size 8 --samples 64 --roughness 0.5 --face-size 16 -o eval.md",
        "export sky.h5 --to gltf -o sky.gltf --size 16 --floor 4",
        "export sky.h5 --to filament -o sky_sh.txt --size 16 --floor 4",
        "export sky.h5 --to threejs-pmrem -o sky.ktx2 --size 16 --floor 4",
        "export splitsum.h5 --to ktx2 -o splitsum.ktx2 --size 16 --floor 4",
    ],
}
"""Two chains of ``shbake`` commands, each run in order by one process."""


def run_chain(name: str) -> None:
    """Run chain ``name`` in a scratch folder, in this process (one interpreter a chain)."""
    from shbake_cli.main import main as shbake

    with tempfile.TemporaryDirectory(prefix=f"shbake-warm-{name}-") as folder:
        shutil.copy(MAP, Path(folder) / "sky.exr")
        os.chdir(folder)
        for command in CHAINS[name]:
            code = shbake([*command.split(), "--quiet"])
            if code != 0:
                raise SystemExit(f"warm_kernels: `shbake {command}` exited {code}")
        os.chdir(ROOT)


def main(names: list[str]) -> None:
    """Run ``names``' chains, or all of them in parallel processes if none is named."""
    if names:
        for name in names:
            run_chain(name)
        return
    start = time.perf_counter()
    runs = [
        subprocess.Popen([sys.executable, "-m", "tests.warm_kernels", name], cwd=ROOT)
        for name in CHAINS
    ]
    if any([r.wait() for r in runs]):
        raise SystemExit(1)
    print(f"warm_kernels: {time.perf_counter() - start:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
