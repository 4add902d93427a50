"""``shbake brdf-table``: tabulate a BRDF's SH product-function coefficients (Kautz et al. 2002)."""

import click
import numpy as np
from shbake_cli.options import (
    BarProgress,
    NameValue,
    SizeHW,
    also_wrote,
    command_line,
    deprecated,
    emit_json,
    exr_dir_opt,
    info,
    info_lines,
    json_opt,
    output_opt,
    png_opt,
    quiet_opt,
    report_opt,
    samples_opt,
    tol_opt,
    usage_errors,
    warn,
)

from shbake.bakers.brdf_table_report import format_report
from shbake.batch.brdf_table import bake_brdf_table, check_parameters
from shbake.brdf import MODELS, model_spec
from shbake.brdf.tabulate import FIRST_LEVEL_POINTS, MAX_SAMPLES_LIMIT
from shbake.conventions import KAUTZ_LMAX_LIMIT


def list_params(ctx, _param, value):
    """``--list-params``: print MODEL's parameters (name, default, range, meaning) and exit.

    MODEL is an eager argument: click processes it before this option wherever it stands on
    the command line (arguments come last in click's invocation order)."""
    if not value or ctx.resilient_parsing:
        return
    model = ctx.params["model"]
    spec = model_spec(model)
    click.echo(f"{model}: {spec.summary}")
    for p in spec.params:
        colour = " (v or r,g,b)" if p.colour else ""
        default = ",".join(f"{v:g}" for v in np.atleast_1d(p.default))  # per-channel defaults
        click.echo(f"  {p.name}={default}  [{p.lo:g}, {p.hi:g}]{colour}  {p.doc}")
    for alias, targets in spec.aliases.items():
        click.echo(f"  {alias}: sets {', '.join(targets)}")
    ctx.exit(0)


@click.command("brdf-table")
@click.argument("model", type=click.Choice(list(MODELS)), is_eager=True)
@output_opt("The brdf_table asset (.h5)")
@click.option(
    "-p",
    "--param",
    "params",
    type=NameValue(),
    multiple=True,
    help="Model parameter (repeatable); colours take v or r,g,b. See --list-params.",
)
@click.option(
    "--list-params",
    is_flag=True,
    expose_value=False,
    callback=list_params,
    help="List MODEL's parameters (name, default, range, meaning) and exit.",
)
@click.option(
    "--merl",
    "merl_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="MERL .binary file (model merl).",
)
@click.option(
    "--lmax",
    type=click.IntRange(0, KAUTZ_LMAX_LIMIT),
    default=4,
    show_default=True,
    help=f"Highest SH band (0…{KAUTZ_LMAX_LIMIT}); (lmax+1)^2 coefficients per view.",
)
@click.option(
    "--size",
    type=SizeHW(),
    default="128",
    show_default=True,
    help="Parabolic map texels: N (square) or HxW, each side 2…4096.",
)
@samples_opt(1024, "per strategy per view texel (ignored with --tol)", hi=1 << 22)
@tol_opt(
    "refine each view texel's nested rules until its error estimate (sqrt(4π) × the largest "
    "coefficient difference to the embedded coarser rules, summed over their 4 axes) is at most TOL"
)
@click.option(
    "--max-samples",
    type=click.IntRange(FIRST_LEVEL_POINTS, MAX_SAMPLES_LIMIT),
    default=1 << 18,
    show_default=True,
    help="Refinement stops here even if --tol is not met (reported, per texel in /error); at "
    f"least the nested rules' first level, {FIRST_LEVEL_POINTS} points, which every texel uses.",
)
@click.option(
    "--vary",
    multiple=True,
    metavar="PARAM=lo:hi:N",
    help="Add a parameter axis (spatially varying BRDFs; repeatable).",
)
@exr_dir_opt("band{l}.exr coefficient textures and the Fig. 2 sheet.png")
@png_opt
@report_opt
@click.option(
    "--reproducible",
    is_flag=True,
    help="Leave the bake time out of the asset (byte-identical rebuilds).",
)
@json_opt
@quiet_opt
@deprecated("--resolution", "size", "--size", type=SizeHW())
@deprecated("--exr", "exr_dir", "--exr-dir", type=click.Path(file_okay=False))
@click.pass_context
def brdf_table(ctx, model, output, params, as_json, quiet, **settings):
    """Tabulate MODEL's BRDF product f*(s,v) = f(s,v) max(0,s_z) as SH per view direction."""
    with usage_errors():
        check_parameters(model, dict(params), settings["vary"])
    summary = bake_brdf_table(
        model,
        output,
        params=dict(params),
        command_line=command_line(ctx),
        progress=BarProgress(quiet),
        **settings,
    )
    for w in summary["warnings"]:
        warn(w, quiet)
    if "report" in summary and not as_json:
        info_lines(format_report(summary["report"]), quiet)
    if as_json:
        emit_json(summary)
    else:
        info(
            f"wrote {output}: {model} {tuple(summary['shape'])}, error {summary['error']:.2e}, "
            f"{summary['seconds']:.1f} s" + also_wrote(summary.get("images", [])),
            quiet,
        )
        info(error_parts(summary), quiet)


def error_parts(summary: dict) -> str:
    """What the headline ``error`` is, and its parts (:func:`shbake.batch.brdf_table.
    table_error`), on one line."""
    p = summary["error_parts"]
    return (
        f"  error: f* rebuilt from the table's look-up vs f* itself, relative L2 over the "
        f"sphere, mean of {p['views']} views; parts: truncation at lmax {summary['lmax']} "
        f"{p['truncation']:.2e}, coefficients (quadrature + bilinear look-up) "
        f"{p['coefficients']:.2e}; quadrature error estimate {p['quadrature_estimate']:.2e}"
    )
