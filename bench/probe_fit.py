"""probe-fit throughput: probes per second on local worker processes, vs split-sum baking.

Usage: ``python bench/probe_fit.py [--probes 200] [--jobs 2] [--dask]``

A probe list of ``--probes`` lines cycles the six shared 512×256 maps (each
line its own output file); ``shbake probe-fit --list … --jobs N`` fits them
all, and the wall time includes starting the workers and building each
worker's plan. The peer in the same run is the split-sum bake of
``shbake split-sum`` (the prefiltered mip chain engines use today: read,
prefilter, write), run in this process on the same maps with its kernels on
``--jobs`` threads, after one warm-up bake. Output: a Markdown table and the ratio.
``--dask`` also fits the list on a ``--jobs``-worker Dask LocalCluster
(loopback) with ``--scheduler`` and compares every file byte for byte with
the local run's.
"""

import argparse
import filecmp
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")


def map_path(name: str) -> Path:
    shared = ROOT.parent / "shared" / "hdri" / f"{name}.exr"
    return shared if shared.exists() else ROOT / "data_samples" / f"{name}.exr"


def timed(args: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "shbake_cli.main", *args], check=True)
    return time.perf_counter() - t0


def split_sum_seconds(n: int, threads: int, tmp: Path) -> float:
    """Wall time of ``n`` split-sum bakes (read, prefilter, write) in this process."""
    from shbake.bakers.dfg import dfg_table
    from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
    from shbake.envmap import load_environment
    from shbake.format.asset import write_asset
    from shbake.format.splitsum import build_splitsum_asset

    os.environ["SHBAKE_THREADS"] = str(threads)  # every kernel: shbake.jit.run_blocks
    config, dfg = SplitSumConfig(), dfg_table()

    def bake(i):
        env = load_environment(str(map_path(MAPS[i % len(MAPS)])), quiet=True)
        chain = prefilter_chain(env.pixels, config)
        write_asset(tmp / f"split{i:05d}.h5", build_splitsum_asset(chain, config, dfg, env.meta))

    bake(0)
    t0 = time.perf_counter()
    for i in range(n):
        bake(i)
    return time.perf_counter() - t0


def dask_run(lines: list[str], workers: int, tmp: Path) -> tuple[float, int]:
    """Fit the same probes on a LocalCluster into ``tmp/dask``; (seconds, identical files)."""
    from distributed import LocalCluster

    folder = tmp / "dask"
    folder.mkdir()
    pairs = [line.split() for line in lines]
    listing = tmp / "dask.txt"
    listing.write_text("".join(f"{src} {folder / Path(out).name}\n" for src, out in pairs))
    with LocalCluster(n_workers=workers, threads_per_worker=1, host="127.0.0.1",
                      dashboard_address=None) as cluster:  # fmt: skip
        seconds = timed(["probe-fit", "--list", str(listing), "--scheduler",
                         cluster.scheduler_address, "-q"])  # fmt: skip
    same = sum(filecmp.cmp(out, folder / Path(out).name, shallow=False) for _, out in pairs)
    return seconds, same


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--probes", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--dask", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        listing = Path(tmp) / "probes.txt"
        lines = [
            f"{map_path(MAPS[i % len(MAPS)])} {Path(tmp) / f'probe{i:05d}.h5'}"
            for i in range(args.probes)
        ]
        listing.write_text("\n".join(lines) + "\n")
        fit = timed(["probe-fit", "--list", str(listing), "--jobs", str(args.jobs), "-q"])
        n_split = min(args.probes, 24)
        split = split_sum_seconds(n_split, args.jobs, Path(tmp))
        if args.dask:
            dask_seconds, same = dask_run(lines, args.jobs, Path(tmp))
    fit_rate, split_rate = args.probes / fit, n_split / split
    print("| bake | probes | wall s | probes/s |")
    print("|---|---|---|---|")
    print(f"| SH-exp `probe-fit --jobs {args.jobs}` | {args.probes} | {fit:.2f} | {fit_rate:.1f} |")
    print(f"| split-sum bake, {args.jobs} threads | {n_split} | {split:.2f} | {split_rate:.1f} |")
    print(f"\nSH-exp / split-sum throughput: {fit_rate / split_rate:.1f}×")
    if args.dask:
        print(
            f"\nDask LocalCluster ({args.jobs} workers): {args.probes} probes in "
            f"{dask_seconds:.2f} s; {same}/{args.probes} files byte-identical to --jobs"
        )


if __name__ == "__main__":
    main()
