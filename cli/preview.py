"""``shbake preview``: render an asset's shading pass (EXR + labelled contact sheet), with diff."""

import click
from click.core import ParameterSource
from shbake_cli.options import (
    BarProgress,
    FiniteRange,
    NameValue,
    also_wrote,
    display_opt,
    emit_json,
    info,
    json_opt,
    output_opt,
    png_opt,
    quiet_opt,
    roughness_opts,
    samples_opt,
    size_opt,
)

from shbake.batch.preview import ALL_PASSES, preview_asset


@click.command("preview")
@click.argument("asset_path", metavar="ASSET", type=click.Path(dir_okay=False))
@click.option(
    "--pass",
    "pass_name",
    type=click.Choice(ALL_PASSES),
    default=None,
    help="Shading pass [default: irradiance; the probe's own pass for probe assets]. "
    "reference: brute force of the asset's kind.",
)
@output_opt("The rendered pass as float32 EXR; a labelled <stem>-sheet.png beside it")
@size_opt(192, "Sphere image size", lo=8)
@click.option(
    "--diff",
    is_flag=True,
    help="Also render the brute-force reference: write it and the signed error as EXRs, "
    "put both in the contact sheet, report MSE and relative RMS error.",
)
@click.option(
    "--source",
    type=click.Path(dir_okay=False),
    default=None,
    help="Original map of the asset (default: its source_path, relative to the asset).",
)
@click.option(
    "--table",
    "table_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="brdf_table asset: needed by --pass kautz; makes --pass reference use its BRDF.",
)
@click.option(
    "--at",
    type=NameValue(number=True),
    multiple=True,
    help="Parameter point of a table with --vary axes, NAME=NUMBER (nearest tabulated value).",
)
@click.option(
    "--merl",
    "merl_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="MERL file of a merl table or SHRM (its reference and --diff need it): the one it "
    "was baked from, SHA-256 checked.",
)
@roughness_opts(0.5, "Probes: the sphere's GGX roughness, within the probe's fitted range")
@click.option(
    "--f0",
    type=FiniteRange(0.0, 1.0),
    default=1.0,
    show_default=True,
    help="Probes: Schlick F0 of the sphere (1 chrome, 0.04 dielectric).",
)
@click.option(
    "--index",
    type=click.IntRange(0),
    default=0,
    show_default=True,
    help="Probe sets: which probe (list order, from 0).",
)
@samples_opt(4096, "per pixel of the probes' glossy reference (visible-normal + map samples)")
@png_opt
@display_opt
@json_opt
@quiet_opt
def preview(asset_path, output, at, as_json, quiet, **settings):
    """Render a sphere lit by ASSET with one shading pass.

    env_sh assets: irradiance, tangent, kautz and their references. Probe
    assets (shexp_probe, shexp_probe_set with --index, splitsum_probe): a GGX
    sphere of --roughness and --f0 shaded by the probe, or the glossy reference.
    """
    ctx = click.get_current_context()
    explicit = {k for k in ctx.params if ctx.get_parameter_source(k) is ParameterSource.COMMANDLINE}
    summary = preview_asset(asset_path, output, at=dict(at), progress=BarProgress(quiet),
                            explicit=explicit, **settings)  # fmt: skip
    for mode, t in summary.get("modes", {}).items():
        info(f"{summary['pass']} {mode}: {t['fps']:.1f} frames/s", quiet)
    if "mse" in summary:
        info(
            f"{summary['pass']} vs brute force: MSE {summary['mse']:.6g}, relative RMS error "
            f"{summary['relative_rms_error']:.4%}",
            quiet,
        )
    if as_json:
        emit_json(summary)
    else:
        info(f"wrote {output} ({summary['pass']}, {summary['fps']:.1f} frames/s)"
             + also_wrote(summary["outputs"][1:]), quiet)  # fmt: skip
