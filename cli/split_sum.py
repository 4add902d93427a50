"""``shbake split-sum``: the split-sum baseline probe (prefiltered octahedral mip chain + DFG)."""

import click
from shbake_cli.options import (
    emit_json,
    fix_nonfinite_opt,
    info,
    json_opt,
    negative_opt,
    parse_range,
    quiet_opt,
)

from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
from shbake.batch.probe_jobs import shared_dfg_table
from shbake.envmap import load_environment
from shbake.errors import InputError
from shbake.format.asset import write_asset
from shbake.format.atomic import check_output_path
from shbake.format.probe import probe_bytes
from shbake.format.splitsum import build_splitsum_asset


@click.command("split-sum")
@click.argument("env", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Asset (.h5).")
@click.option(
    "--top",
    type=int,
    default=128,
    show_default=True,
    help="Size of the first (roughest-detail) level.",
)
@click.option("--min-size", type=int, default=32, show_default=True, help="Smallest level size.")
@click.option("--levels", type=int, default=5, show_default=True, help="Roughness levels.")
@click.option(
    "--roughness-range", default="0.2:1", show_default=True, help="Perceptual roughness lo:hi."
)
@click.option("--samples", type=int, default=1024, show_default=True, help="GGX samples per texel.")
@negative_opt
@fix_nonfinite_opt
@json_opt
@quiet_opt
def split_sum(
    env,
    output,
    top,
    min_size,
    levels,
    roughness_range,
    samples,
    negative,
    fix_nonfinite,
    as_json,
    quiet,
):
    """Bake the split-sum baseline of ENV (Karis 2013) as a probe asset of its own."""
    lo, hi = parse_range(roughness_range, "--roughness-range")
    config = SplitSumConfig(top, min_size, levels, lo, hi, samples)
    check_output_path(output)
    environment = load_environment(env, negative=negative, fix_nonfinite=fix_nonfinite, quiet=quiet)
    if environment.layout != "latlong":
        raise InputError(f"{env}: split-sum takes lat-long maps (2:1), got {environment.layout}")
    chain = prefilter_chain(environment.pixels, config)
    asset = build_splitsum_asset(chain, config, shared_dfg_table(), environment.meta)
    write_asset(output, asset)
    info(f"split-sum: {output}: {levels} levels, {probe_bytes(asset)} bytes", quiet)
    if as_json:
        emit_json({"output": output, "bytes": probe_bytes(asset), "config": config.as_dict()})
