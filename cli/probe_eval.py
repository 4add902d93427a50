"""``shbake probe-eval``: SH-exp v2, the paper's SH-exp and both split-sums against ground truth."""

import click
from shbake_cli.options import (
    deprecated,
    emit_json,
    info,
    json_opt,
    output_opt,
    quiet_opt,
    samples_opt,
    size_opt,
)

from shbake.batch.probe_eval import COMPARISONS, evaluate_maps, markdown_report, win_table
from shbake.format.atomic import check_output_path, refuse_same_file, write_text


@click.command("probe-eval")
@click.argument("maps", nargs=-1, required=True, type=click.Path(dir_okay=False))
@output_opt("Markdown report: win rates per α and material, bytes, every case", required=False)
@size_opt(32, "Sphere image size", lo=8, hi=512)
@samples_opt(4096, "per pixel of the ground truth (visible-normal + map samples)")
@deprecated("--truth-samples", "samples", "--samples", type=int)
@deprecated("--markdown", "output", "-o/--output", type=click.Path(dir_okay=False))
@click.option(
    "--sheet-dir",
    type=click.Path(file_okay=False),
    default=None,
    help="Folder for one labelled contact sheet per case (SH-exp v2 | ground truth | error).",
)
@json_opt
@quiet_opt
def probe_eval(maps, output, size, samples, sheet_dir, as_json, quiet):
    """Measure the probes of MAPS against ground truth.

    Cases: chrome (F0 1) and dielectric (F0 0.04) × the paper's GGX widths
    α = 0.25, 0.36, 0.49, 0.64, 0.81, 1 × four views; error: MSE over the
    sphere. Probes: SH-exp v2 (default fit), the paper's SH-exp (--sets 1
    --weights log), split-sum plain (1024 samples per texel, levels at those
    α) and filtered (engine-grade).
    """

    if output is not None:  # checked (and compared with every map read) before any work
        check_output_path(output)
        refuse_same_file([output], maps)

    def progress(name, rows):
        wins = sum(r["mse"]["shexp_v2"] < r["mse"]["splitsum_plain"] for r in rows)
        info(f"probe-eval: {name}: SH-exp v2 beats plain split-sum in {wins}/{len(rows)}", quiet)

    result = evaluate_maps(maps, size, samples, progress, sheet_dir=sheet_dir)
    totals = {f"{m} vs {b}": win_table(result, m, b)["total"] for m, b in COMPARISONS}
    for k, (w, n) in totals.items():
        info(f"probe-eval: {k}: {w}/{n} ({w / n:.0%})", quiet)
    if output:
        write_text(output, markdown_report(result))
    if as_json:
        emit_json(result | {"totals": totals})
