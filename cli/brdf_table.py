"""``shbake brdf-table``: tabulate a BRDF's SH product-function coefficients (Kautz et al. 2002)."""

import os
import sys

import click
from shbake_cli.options import emit_json, info, json_opt, quiet_opt
from shbake_cli.project_env import command_line

from shbake.bakers.kautz_report import format_report, settings_report
from shbake.brdf import MODELS, make_brdf
from shbake.brdf.tabulate import parse_vary, tabulate_axes
from shbake.conventions import KAUTZ_LMAX_LIMIT, check_lmax
from shbake.errors import ParameterError
from shbake.format.asset import write_asset
from shbake.format.atomic import check_writable_dir
from shbake.format.kautz_images import write_band_exrs, write_sheet
from shbake.format.kautz_table import build_table_asset, table_at


def parse_params(items) -> dict:
    """``("nu=24", "Rs=0.9,0.8,0.7")`` → ``{"nu": "24", "Rs": "0.9,0.8,0.7"}``."""
    out = {}
    for item in items:
        if "=" not in item:
            raise ParameterError(f"-p {item!r}: expected NAME=VALUE")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def parse_resolution(text: str) -> tuple[int, int]:
    """``"128"`` or ``"128x64"`` (height x width)."""
    try:
        parts = [int(p) for p in text.lower().split("x")]
    except ValueError:
        raise ParameterError(f"--resolution {text!r}: expected N or HxW") from None
    if len(parts) == 1:
        parts *= 2
    if len(parts) != 2 or not all(2 <= p <= 4096 for p in parts):
        raise ParameterError(f"--resolution {text!r}: sides must be in [2, 4096]")
    return parts[0], parts[1]


def _progress(quiet):
    if quiet or not sys.stderr.isatty():
        return None

    def show(point, points, samples, err):
        click.echo(
            f"\rtable {point + 1}/{points}: {samples} samples, error estimate {err:.2e}   ",
            err=True,
            nl=False,
        )

    return show


@click.command("brdf-table")
@click.argument("model", type=click.Choice(list(MODELS)))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Asset (.h5).")
@click.option(
    "-p",
    "--param",
    "params",
    multiple=True,
    metavar="NAME=VALUE",
    help="Model parameter (repeatable); colours take v or r,g,b. See --list-params.",
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
    type=int,
    default=4,
    show_default=True,
    help=f"Highest SH band (0…{KAUTZ_LMAX_LIMIT}); (lmax+1)^2 coefficients.",
)
@click.option(
    "--resolution", default="128", show_default=True, metavar="N|HxW", help="Parabolic map size."
)
@click.option(
    "--samples",
    type=int,
    default=1024,
    show_default=True,
    help="Quadrature points per strategy (ignored with --tol).",
)
@click.option(
    "--tol",
    type=float,
    default=None,
    help="Refine each texel until its error estimate is below TOL.",
)
@click.option(
    "--max-samples",
    type=int,
    default=1 << 18,
    show_default=True,
    help="Refinement stops here even if --tol is not met (reported).",
)
@click.option(
    "--vary",
    multiple=True,
    metavar="PARAM=lo:hi:N",
    help="Add a parameter axis (spatially varying BRDFs; repeatable).",
)
@click.option(
    "--exr",
    "exr_dir",
    type=click.Path(file_okay=False),
    default=None,
    help="Write band{l}.exr component textures and sheet.png here.",
)
@click.option(
    "--report", is_flag=True, help="Measure error and time vs lmax, resolution and samples."
)
@click.option(
    "--reproducible",
    is_flag=True,
    help="Leave the bake time out of the asset (byte-identical rebuilds).",
)
@json_opt
@quiet_opt
@click.pass_context
def brdf_table(
    ctx,
    model,
    output,
    params,
    merl_path,
    lmax,
    resolution,
    samples,
    tol,
    max_samples,
    vary,
    exr_dir,
    report,
    reproducible,
    as_json,
    quiet,
):
    """Tabulate MODEL's BRDF product f*(s,v) = f(s,v) max(0,s_z) as SH per view direction."""
    lmax = check_lmax(lmax, limit=KAUTZ_LMAX_LIMIT)
    res = parse_resolution(resolution)
    brdf = make_brdf(model, merl_path=merl_path, **parse_params(params))
    axes = [parse_vary(v) for v in vary]
    check_writable_dir(output)
    if exr_dir:
        os.makedirs(exr_dir, exist_ok=True)
    tables, convs = tabulate_axes(
        brdf,
        axes,
        progress=_progress(quiet),
        lmax=lmax,
        resolution=res,
        samples=None if tol is not None else samples,
        tol=tol,
        max_samples=max_samples,
    )
    if _progress(quiet):
        click.echo("", err=True)
    asset = build_table_asset(brdf, tables, convs, axes, lmax, record_time=not reproducible)
    asset.attrs["command_line"] = command_line(ctx)
    write_asset(output, asset)
    tattrs = asset.dataset_attrs["/table"]
    err = tattrs["error_estimate"]
    seconds = sum(c.seconds for c in convs)
    if tol is not None and err > tol:
        bad = int(sum((c.view_errors > tol).sum() for c in convs))
        info(
            f"warning: {bad} texels did not reach --tol {tol:g} by {max_samples} samples "
            f"(largest error estimate {err:.2e}; see /error)",
            quiet,
        )
    if not tattrs["energy_conserving"]:
        info(
            f"warning: measured albedo up to {max(tattrs['max_albedo']):.4f} > 1: these "
            "parameters do not conserve energy (flagged in the asset)",
            quiet,
        )
    summary = {
        "output": output,
        "model": model,
        "parameters": brdf.describe()["parameters"],
        "lmax": lmax,
        "resolution": list(res),
        "shape": list(asset["/table"].shape),
        "error_estimate": err,
        "samples_max": tattrs["samples_max"],
        "seconds": seconds,
        "max_albedo": tattrs["max_albedo"],
        "energy_conserving": tattrs["energy_conserving"],
    }
    if exr_dir:
        written = []
        point = table_at(asset)
        written += write_band_exrs(exr_dir, point.coeffs, lmax, brdf.coloured)
        sheet_path = os.path.join(exr_dir, "sheet.png")
        write_sheet(sheet_path, point.coeffs, lmax)
        summary["images"] = written + [sheet_path]
    if report:
        rep = settings_report(
            brdf, lmax, res, samples if tol is None else convs[0].samples, convs[0].history
        )
        summary["report"] = rep
        if not as_json:
            click.echo(format_report(rep), err=True)
    if as_json:
        emit_json(summary)
    else:
        info(
            f"wrote {output}: {model} {tuple(asset['/table'].shape)}, error estimate "
            f"{err:.2e}, {seconds:.1f} s",
            quiet,
        )
