"""Run every benchmark and print the Markdown tables of docs/BENCHMARKS.md."""

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

SCRIPTS = (
    ["projection.py"],
    ["end_to_end.py"],
    ["irradiance_accuracy.py"],
    ["brdf_table.py"],
    ["probe_fit.py"],
    ["probe_throughput.py", "--dask", "60"],
    ["probe_targets.py"],
    ["probe_eval.py"],
)

for script, *args in SCRIPTS:
    print(f"\n## {script}\n", flush=True)
    subprocess.run([sys.executable, str(HERE / script), *args], check=True)
