"""SH-exp v2 and the paper's SH-exp against both split-sums on the six shared maps.

Usage: ``python bench/probe_eval.py [--jobs 2] [--size 32] [--truth-samples 2048]
[--roughness R …] [--yaw DEG …] [--eps 0.01] [--face-size 64] [--no-shrm] [--out PREFIX]
[MAP …]``

The three-way table of ``docs/BENCHMARKS.md`` (SH-exp, split-sum, GGX SHRM at
ε = 0.01; issue 13)::

    python bench/probe_eval.py --jobs 2 --truth-samples 4096 --roughness 0.25 0.4 0.5 \
        --out bench/results/probe_eval_shrm

The planner's dielectric limit (α 0.2) and the views the acceptance does not score::

    python bench/probe_eval.py --jobs 2 --no-shrm --roughness 0.4472136 \
        --out bench/results/probe_eval_alpha02
    python bench/probe_eval.py --jobs 2 --no-shrm --yaw 45 135 225 315 \
        --out bench/results/probe_eval_heldout

Runs :func:`shbake.batch.probe_eval.evaluate_maps` (2 materials × the paper's
six α × 4 views per map, or ``--roughness``/``--yaw``'s) with one process per map
(``--jobs`` at a time, numba on one thread each) and writes ``bench/results/probe_eval.json`` (every
case, with each probe's bake seconds per map) and ``bench/results/probe_eval.md`` (win
rates per α and material, bytes per probe and mean bake seconds, the per-map table and every
case). ``SHBAKE_TRUTH_CACHE=DIR`` keeps
the ground truths there (they do not depend on the probes) for re-runs.
``tests/accuracy/test_probe_eval.py`` asserts the figures of the JSON.
"""

import argparse
import json
import os
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
RESULTS = ROOT / "bench" / "results"


def one_map(args):
    path, size, samples, roughness, eps, face_size, yaws = args
    from shbake.batch.probe_eval import evaluate_maps
    from shbake.evaluation.probes import VIEW_YAWS
    from shbake.jit import use_one_thread

    use_one_thread()

    return evaluate_maps([path], size, samples, cache_dir=os.environ.get("SHBAKE_TRUTH_CACHE"),
                         roughness=roughness, shrm_eps=eps, shrm_face_size=face_size,
                         yaws=yaws or VIEW_YAWS)  # fmt: skip


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("maps", nargs="*")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--size", type=int, default=32)
    ap.add_argument("--truth-samples", type=int, default=2048)
    ap.add_argument("--roughness", type=float, nargs="+", default=None,
                    help="perceptual roughness of the cases (default: the paper's six)")
    ap.add_argument("--yaw", type=float, nargs="+", default=None,
                    help="view yaws of the cases in degrees (default the paper's 0 90 180 270)")
    ap.add_argument("--eps", type=float, default=0.01, help="GGX SHRM tolerance")
    ap.add_argument("--face-size", type=int, default=64, help="GGX SHRM face size")
    ap.add_argument("--no-shrm", action="store_true", help="leave the GGX SHRM out")
    ap.add_argument("--out", default=str(RESULTS / "probe_eval"))
    args = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    paths = args.maps or [str(ROOT.parent / "shared" / "hdri" / f"{m}.exr") for m in MAPS]
    eps = None if args.no_shrm else args.eps
    work = [(p, args.size, args.truth_samples, args.roughness, eps, args.face_size, args.yaw)
            for p in paths]  # fmt: skip
    with ProcessPoolExecutor(args.jobs, mp_context=get_context("spawn")) as pool:
        parts = list(pool.map(one_map, work))
    result = parts[0]
    for part in parts[1:]:
        result["maps"].update(part["maps"])
        result["seconds"].update(part["seconds"])
    from shbake.batch.probe_eval import markdown_report

    Path(args.out + ".json").write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    report = markdown_report(result)
    Path(args.out + ".md").write_text(report)
    print(report.split("\n\n")[0])


if __name__ == "__main__":
    main()
