"""Regenerate the speed tables of docs/BENCHMARKS.md (issue 15): ``make bench`` runs this.

Runs bench/projection.py, bench/evaluate.py and bench/end_to_end.py (each a
fresh process, ``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``), and replaces
the text between the ``speed tables`` markers of docs/BENCHMARKS.md with
their output, the date and the commands. The file is replaced atomically.

    .venv/bin/python bench/speed_tables.py [N]
"""

import datetime
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
DOC = HERE.parent / "docs" / "BENCHMARKS.md"
BEGIN = "<!-- speed tables: begin (bench/speed_tables.py writes this part) -->"
END = "<!-- speed tables: end -->"

SECTIONS = (
    ("Projection: shbake vs ducc0 vs the previous shbake", "projection.py"),
    ("SH reconstruction: evaluate vs sphericart + matmul", "evaluate.py"),
    (
        "Whole process: project-env vs a plain OpenImageIO + ducc0 + h5py script; "
        "preview passes at 512²",
        "end_to_end.py",
    ),
)


def main(n: int = 7) -> None:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    parts = [
        BEGIN,
        "",
        f"Generated {datetime.date.today().isoformat()} by `make bench` "
        f"(`bench/speed_tables.py {n}`). Each table: median (min–max) of {n} runs, the peer "
        "timed in the same process (or the same loop), interleaved run by run; ratios are "
        "per-run-pair medians. The machine line gives the load average when the script "
        "started: on a shared machine read the ratios, not the absolute times.",
    ]
    for title, script in SECTIONS:
        cmd = [sys.executable, str(HERE / script), str(n)]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=env).stdout
        shown = f"OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/{script} {n}"
        parts += ["", f"### {title}", "", f"`{shown}`", "", out.strip()]
        print(f"{script}: done", file=sys.stderr)
    parts += ["", END]
    text = DOC.read_text(encoding="utf-8")
    block = "\n".join(parts)
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
        text = head + block + tail
    else:
        text = text.rstrip("\n") + "\n\n## Speed (issue 15)\n\n" + block + "\n"
    fd, tmp = tempfile.mkstemp(dir=DOC.parent, prefix=".BENCHMARKS.", suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, DOC)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
