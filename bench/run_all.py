"""Run every benchmark: the speed tables are written into docs/BENCHMARKS.md
(bench/speed_tables.py); the other tables are printed for the document."""

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

SCRIPTS = (
    ["speed_tables.py"],
    ["irradiance_accuracy.py"],
    ["brdf_table.py"],
    ["probe_fit.py"],
    ["probe_throughput.py", "--dask", "60"],
    ["probe_targets.py"],
    ["probe_eval.py", "--no-shrm"],
    ["probe_eval.py", "--truth-samples", "4096", "--roughness", "0.25", "0.4", "0.5",
     "--out", str(HERE / "results" / "probe_eval_shrm")],
    ["shrm.py", "--sections", "energy", "--out", str(HERE / "results" / "shrm_energy.md")],
)

for script, *args in SCRIPTS:
    print(f"\n## {script}\n", flush=True)
    subprocess.run([sys.executable, str(HERE / script), *args], check=True)
