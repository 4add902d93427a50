"""``shbake probe-eval``: SH-exp vs split-sum against ground truth on rendered spheres."""

from pathlib import Path

import click
from shbake_cli.options import (
    deprecated,
    emit_json,
    info,
    json_opt,
    quiet_opt,
    samples_opt,
    size_opt,
)

from shbake.bakers.shexp import FitConfig
from shbake.bakers.splitsum import SplitSumConfig
from shbake.batch.probe_eval import evaluate_map
from shbake.batch.probe_jobs import fit_plan, shared_dfg_table
from shbake.envmap import load_environment
from shbake.errors import InputError
from shbake.format.atomic import check_output_path, refuse_same_file, write_text
from shbake.format.probe import probe_bytes


def markdown_table(results: dict) -> str:
    lines = [
        "| map | material | roughness | view yaw | MSE SH-exp | MSE split-sum | ratio | winner "
        "| truth MSE (est.) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, rows in results.items():
        for r in rows:
            ratio = r["mse_shexp"] / r["mse_splitsum"] if r["mse_splitsum"] > 0 else float("inf")
            lines.append(
                f"| {name} | {r['material']} | {r['roughness']:.2f} | {r['yaw']:.0f} | "
                f"{r['mse_shexp']:.3e} | {r['mse_splitsum']:.3e} | {ratio:.2f} | "
                f"{'SH-exp' if r['shexp_wins'] else 'split-sum'} | {r['mse_truth_estimate']:.1e} |"
            )
    return "\n".join(lines) + "\n"


@click.command("probe-eval")
@click.argument("maps", nargs=-1, required=True, type=click.Path(dir_okay=False))
@size_opt(32, "Evaluation sphere size", lo=8, hi=512)
@samples_opt(4096, "per pixel of the ground truth (visible-normal + map samples, MIS)")
@click.option(
    "--markdown",
    type=click.Path(dir_okay=False),
    help="Write the case table here as Markdown (a file).",
)
@json_opt
@quiet_opt
@deprecated("--truth-samples", "samples", "--samples", type=click.IntRange(16, 1 << 20))
def probe_eval(maps, size, samples, markdown, as_json, quiet):
    """Measure SH-exp and split-sum probes of MAPS against ground truth.

    Cases: chrome (F0 1) and dielectric (F0 0.04), roughness 0.25–1.0, four
    views; error: MSE over the sphere. Default fit and split-sum settings.
    """
    if markdown is not None:  # checked (and compared with every map read) before any work
        check_output_path(markdown, "--markdown")
        refuse_same_file([markdown], maps)
    dfg = shared_dfg_table()
    split_config = SplitSumConfig()
    results, sizes = {}, {}
    for path in maps:
        env = load_environment(path, quiet=True)
        if env.layout != "latlong":
            raise InputError(f"{path}: probe-eval takes lat-long maps (2:1)")
        plan = fit_plan(FitConfig(), env.shape)
        rows, a, b = evaluate_map(env, plan, split_config, dfg, size, samples)
        name = Path(path).stem
        results[name] = rows
        sizes = {"shexp_bytes": probe_bytes(a), "splitsum_bytes": probe_bytes(b)}
        wins = sum(r["shexp_wins"] for r in rows)
        info(f"probe-eval: {name}: SH-exp wins {wins}/{len(rows)}", quiet)
    total = sum(len(r) for r in results.values())
    wins = sum(x["shexp_wins"] for r in results.values() for x in r)
    ties = sum(
        abs(x["mse_shexp"] - x["mse_splitsum"]) < x["mse_truth_estimate"]
        for r in results.values()
        for x in r
    )
    info(f"probe-eval: SH-exp wins {wins}/{total} ({wins / total:.0%}); {ties} cases differ by "
         f"less than the truth's own error; bytes per probe {sizes['shexp_bytes']} vs "
         f"{sizes['splitsum_bytes']}", quiet)  # fmt: skip
    if markdown is not None:
        write_text(markdown, markdown_table(results))
    if as_json:
        emit_json({"cases": results, "wins": wins, "total": total, "ties": ties, **sizes})
