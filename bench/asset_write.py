"""Cost of writing an asset through an in-memory HDF5 image (what ``write_asset`` does)
against HDF5 writing the file directly (the writer before issue 27, which a free-space
check before writing would have kept).

Each asset is read back (``read_asset``), then written once per method in a fresh
process: wall seconds of the write, and the growth of the process's peak resident memory
(``ru_maxrss``) during it. Both methods are checked to give the same bytes.

    python bench/asset_write.py ASSET.h5 [ASSET.h5 ...]
    python bench/asset_write.py --cpu ASSET.h5 [ASSET.h5 ...]

``--cpu``: process CPU time of one ``write_asset`` of each asset (read back first), the
median of 5 batches of 60 writes in this process (issue 31: the low-level writer).
"""

import os
import resource
import subprocess
import sys
import tempfile
import time

METHODS = ("direct", "image")


def _peak() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def measure(path: str, method: str, out: str) -> tuple[float, int]:
    """Write the asset at ``path`` to ``out`` by ``method``; (seconds, peak growth bytes)."""
    import h5py

    from shbake.format.asset import WRITE_OPTIONS, Asset, read_asset, write_asset, write_into
    from shbake.format.provenance import relativise

    asset = read_asset(path)
    asset = Asset(asset.kind, relativise(asset.attrs, out), asset.datasets, asset.dataset_attrs)
    before = _peak()
    t0 = time.perf_counter()
    if method == "direct":
        with h5py.File(out, "w", **WRITE_OPTIONS) as f:
            write_into(f, asset)
    else:
        write_asset(out, asset)
    return time.perf_counter() - t0, _peak() - before


def main(paths):
    print("| asset | bytes | direct s | image s | direct peak +MiB | image peak +MiB |")
    print("|---|---:|---:|---:|---:|---:|")
    for path in paths:
        row, files = {}, {}
        with tempfile.TemporaryDirectory(dir=os.path.dirname(os.path.abspath(path))) as tmp:
            for method in METHODS:
                out = os.path.join(tmp, f"{method}.h5")
                res = subprocess.run([sys.executable, __file__, "--one", path, method, out],
                                     check=True, capture_output=True, text=True)  # fmt: skip
                row[method] = [float(x) for x in res.stdout.split()]
                with open(out, "rb") as f:
                    files[method] = f.read()
        assert files["direct"] == files["image"], f"{path}: bytes differ"
        mib = 1 << 20
        print(f"| {os.path.basename(path)} | {len(files['image'])} | {row['direct'][0]:.3f} | "
              f"{row['image'][0]:.3f} | {row['direct'][1] / mib:.1f} | "
              f"{row['image'][1] / mib:.1f} |")  # fmt: skip


def cpu_per_write(paths, batches: int = 5, writes: int = 60):
    """Print the CPU milliseconds of one ``write_asset`` of each asset at ``paths``."""
    from shbake.format.asset import read_asset, write_asset

    print("| asset | kind | write_asset CPU ms (median of batches) |")
    print("|---|---|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for i, path in enumerate(paths):
            asset = read_asset(path)
            out = os.path.join(tmp, f"{i}.h5")
            write_asset(out, asset)  # first write: imports, caches
            per = []
            for _ in range(batches):
                t0 = time.process_time()
                for _ in range(writes):
                    write_asset(out, asset)
                per.append((time.process_time() - t0) / writes)
            median = sorted(per)[batches // 2]
            print(f"| {os.path.basename(path)} | {asset.kind} | {median * 1e3:.2f} |")


if __name__ == "__main__":
    if sys.argv[1] == "--cpu":
        cpu_per_write(sys.argv[2:])
    elif sys.argv[1] == "--one":
        seconds, grown = measure(*sys.argv[2:5])
        print(seconds, grown)
    else:
        main(sys.argv[1:])
