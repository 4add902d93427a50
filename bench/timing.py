"""Shared timing helpers of the speed benchmarks (issue 15).

Every figure is the median of N ≥ 5 runs after a warm-up, with the range
(min–max); peers are timed in the same process, interleaved run by run, and
ratios are taken per run pair, then their median — so a busy machine (these
share 2 cores) moves both sides of a ratio together. ``thread_time`` (CPU
time of the calling thread) is reported for 1-thread rows, wall time for
multi-thread rows.
"""

import importlib.util
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PREVIOUS = "2b78de2"
"""The tree before issue 15 (the 'previous release' of the tables)."""


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (
        f"{cpu}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
        f"load average {load:.1f} at start"
    )


def interleaved(fns: dict, n: int = 7, clock=time.perf_counter) -> dict:
    """``{name: [seconds, …]}``: each function once per round, ``n`` rounds after a warm-up."""
    for f in fns.values():
        f()
    out = {k: [] for k in fns}
    for _ in range(n):
        for k, f in fns.items():
            t0 = clock()
            f()
            out[k].append(clock() - t0)
    return out


def med(xs, scale=1e3, fmt="{:.1f}") -> str:
    """``median (min–max)`` in ms by default."""
    return (fmt + " ({}–{})").format(
        statistics.median(xs) * scale, fmt.format(min(xs) * scale), fmt.format(max(xs) * scale)
    )


def ratio(num, den) -> str:
    """Median and range of the per-round ratios ``num[i] / den[i]``."""
    r = [a / b for a, b in zip(num, den, strict=True)]
    return f"{statistics.median(r):.2f} ({min(r):.2f}–{max(r):.2f})"


def previous_module(relpath: str, name: str, commit: str = PREVIOUS):
    """Import ``relpath`` as it was at ``commit`` (a same-run 'before' column), or None."""
    try:
        src = subprocess.run(
            ["git", "show", f"{commit}:{relpath}"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    folder = Path(os.environ.get("TMPDIR", "/tmp")) / "shbake-bench-previous"
    folder.mkdir(exist_ok=True)
    path = folder / f"{name}.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod
