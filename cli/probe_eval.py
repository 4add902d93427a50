"""``shbake probe-eval``: SH-exp v2, the paper's SH-exp, both split-sums and the GGX SHRM
against ground truth."""

import click
from shbake_cli.options import (
    FiniteRange,
    deprecated,
    emit_json,
    info,
    json_opt,
    output_opt,
    quiet_opt,
    samples_opt,
    size_opt,
    usage_errors,
    warn,
)

from shbake.bakers.shrm import FACE_MAX, FACE_MIN
from shbake.batch.probe_eval import (
    ROUGHNESS_MIN,
    SHRM_EPS,
    SHRM_FACE_SIZE,
    check_evaluation,
    check_map_names,
    evaluate_maps,
    markdown_report,
    mean_bake_seconds,
    present_comparisons,
    shrm_shortfalls,
    win_table,
)
from shbake.conventions import SAMPLES_LIMIT
from shbake.format.atomic import check_output_path, refuse_same_file, write_text


@click.command("probe-eval")
@click.argument("maps", nargs=-1, required=True, type=click.Path(dir_okay=False))
@output_opt(
    "Markdown report: win rates per α and material, bytes and bake seconds, every case",
    required=False,
)
@size_opt(32, "Sphere image size", lo=8, hi=512)
@samples_opt(4096, "per pixel of the ground truth (visible-normal + map samples)")
@deprecated("--truth-samples", "samples", "--samples", type=click.IntRange(16, SAMPLES_LIMIT))
@deprecated("--markdown", "output", "-o/--output", type=click.Path(dir_okay=False))
@click.option(
    "--roughness",
    multiple=True,
    type=FiniteRange(ROUGHNESS_MIN, 1.0),
    help=f"Cases at this perceptual roughness r in [{ROUGHNESS_MIN:g}, 1] (GGX width α = r²; "
    "repeatable) "
    "[default: the paper's 0.5, 0.6, …, 1.0].",
)
@click.option(
    "--eps",
    "--tol",
    "eps",
    type=FiniteRange(0.0, 1.0, min_open=True, max_open=True),
    default=SHRM_EPS,
    show_default=True,
    help="Error tolerance in (0, 1) of the GGX SHRM: the fraction of BRDF energy left out; "
    "chooses F and P within F ≤ 64, P ≤ 16 (RH02 §5.1; a shortfall is reported).",
)
@click.option(
    "--face-size",
    type=click.IntRange(FACE_MIN, FACE_MAX),
    default=SHRM_FACE_SIZE,
    show_default=True,
    help=f"Cube face size in texels ({FACE_MIN}…{FACE_MAX}) of the GGX SHRM.",
)
@click.option(
    "--shrm/--no-shrm",
    default=True,
    show_default=True,
    help="Evaluate the GGX SHRM (an E0 and an E1 SHRM per roughness).",
)
@click.option(
    "--sheet-dir",
    type=click.Path(file_okay=False),
    default=None,
    help="Folder for one labelled contact sheet per case (SH-exp v2 | ground truth | error).",
)
@json_opt
@quiet_opt
def probe_eval(maps, output, size, samples, roughness, eps, face_size, shrm, sheet_dir, as_json,
               quiet):  # fmt: skip
    """Measure the probes of MAPS against ground truth.

    Cases: chrome (F0 1) and dielectric (F0 0.04) × the paper's GGX widths
    α = 0.25, 0.36, 0.49, 0.64, 0.81, 1 (or --roughness) × four views; error:
    MSE over the sphere. Probes: SH-exp v2 (default fit), the paper's SH-exp
    (--sets 1 --weights log --alpha-weight 0), split-sum plain (1024 samples per texel, levels
    at those α), split-sum filtered (engine-grade) and the GGX SHRM (E0 and E1
    SHRMs per α by the shrm command's baker, orders from --eps). A probe that
    does not cover an α (SH-exp: α < 0.2) reports n/a there. Each probe's
    bake is timed per map (wall seconds; --json: "seconds", the report: the
    mean next to its bytes).
    """
    with usage_errors():
        check_evaluation(roughness or None, eps if shrm else None, face_size)
        check_map_names(maps)
    if output is not None:  # checked (and compared with every map read) before any work
        check_output_path(output)
        refuse_same_file([output], maps)

    def progress(name, rows):
        for m in ("shexp_v2", "shrm"):
            pairs = [(r["mse"].get(m), r["mse"]["splitsum_plain"]) for r in rows]
            pairs = [(a, b) for a, b in pairs if a is not None]
            if pairs:
                wins = sum(a < b for a, b in pairs)
                info(f"probe-eval: {name}: {m} beats plain split-sum in {wins}/{len(pairs)}",
                     quiet)  # fmt: skip

    result = evaluate_maps(maps, size, samples, progress, sheet_dir=sheet_dir,
                           roughness=roughness or None, shrm_eps=eps if shrm else None,
                           shrm_face_size=face_size)  # fmt: skip
    for line in shrm_shortfalls(result):
        warn(line, quiet)
    totals = {f"{m} vs {b}": win_table(result, m, b)["total"]
              for m, b in present_comparisons(result)}  # fmt: skip
    for k, (w, n) in totals.items():
        info(f"probe-eval: {k}: {w}/{n} ({w / n:.0%})", quiet)
    means = mean_bake_seconds(result)
    info(f"probe-eval: bake s (mean of {len(result['seconds'])} map"
         f"{'s' if len(result['seconds']) != 1 else ''}): "
         + ", ".join(f"{k} {v:.3g}" for k, v in means.items()), quiet)  # fmt: skip
    if output:
        write_text(output, markdown_report(result))
    if as_json:
        emit_json(result | {"totals": totals})
