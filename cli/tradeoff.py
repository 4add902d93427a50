"""``shbake tradeoff``: error against time and bytes for one asset kind's candidate settings."""

import click
from shbake_cli.options import (
    FiniteRange,
    NameValue,
    also_wrote,
    emit_json,
    info,
    json_opt,
    output_opt,
    quiet_opt,
    samples_opt,
    usage_errors,
)

from shbake.batch.brdf_table import check_parameters
from shbake.batch.tradeoff import TRADEOFF_KINDS, tradeoff_files
from shbake.brdf import MODELS


@click.command("tradeoff")
@click.argument("kind", type=click.Choice(TRADEOFF_KINDS))
@click.option("--map", "map_path", type=click.Path(dir_okay=False), default=None,
              help="The environment map (env_sh).")
@click.option("--model", type=click.Choice(list(MODELS)), default=None,
              help="The BRDF model (brdf_table).")
@click.option("-p", "--param", "params", type=NameValue(), multiple=True,
              help="Model parameter NAME=VALUE (repeatable; brdf_table).")
@click.option("--tol", type=FiniteRange(0.0, 1.0, min_open=True, max_open=True),
              default=0.05, show_default=True,
              help="Error tolerance in (0, 1): drawn, and the setting shbake plan picks for "
              "it is marked, by the errors alone (env_sh: relative RMS irradiance error, the "
              "smallest lmax meeting it; brdf_table: relative L2 of f*, plan's lmax, then the "
              "smallest size meeting it).")
@samples_opt(256, "per strategy per table texel (brdf_table)")
@output_opt("The plot (PNG)")
@click.option("--csv", "csv_path", type=click.Path(dir_okay=False), default=None,
              help="Also write the numbers as CSV.")
@click.option("--json-file", "json_path", type=click.Path(dir_okay=False), default=None,
              help="Also write the numbers as JSON.")
@json_opt
@quiet_opt
def tradeoff_cmd(kind, map_path, model, params, tol, samples, output, csv_path, json_path,
                 as_json, quiet):  # fmt: skip
    """Plot error vs time and bytes of KIND's candidate settings (env_sh: lmax; brdf_table:
    lmax × size), the tolerance and the chosen point."""
    if model is not None:
        with usage_errors():
            check_parameters(model, dict(params))
    result = tradeoff_files(kind, tol, output, csv_path, json_path, map_path=map_path,
                            model=model, params=dict(params), samples=samples)  # fmt: skip
    if as_json:
        emit_json(result)
    else:
        info(f"tradeoff: {output}: {len(result['rows'])} settings, chosen {chosen_text(result)}"
             + also_wrote([p for p in (csv_path, json_path) if p]), quiet)  # fmt: skip


def chosen_text(result: dict) -> str:
    """The chosen setting with its error, time and bytes, or that none meets the tolerance."""
    row = next((r for r in result["rows"] if r["setting"] == result["chosen"]), None)
    if row is None:
        return "none (tolerance not met)"
    return (f"{row['setting']} ({result['error_label']} {row['error']:.3g}, "
            f"{row['seconds'] * 1e3:.3g} ms, {row['bytes']} bytes)")  # fmt: skip
