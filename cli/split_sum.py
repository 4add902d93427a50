"""``shbake split-sum``: the split-sum baseline probe (prefiltered octahedral mip chain + DFG)."""

import click
from shbake_cli.options import (
    deprecated,
    emit_json,
    fix_nonfinite_opt,
    info,
    json_opt,
    negative_opt,
    output_opt,
    parse_range,
    quiet_opt,
    samples_opt,
    size_opt,
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
@output_opt("The splitsum_probe asset (.h5)")
@size_opt(128, "Octahedral texels of the first (sharpest) level", lo=8, hi=2048)
@click.option(
    "--min-size",
    type=click.IntRange(8, 2048),
    default=32,
    show_default=True,
    help="Octahedral texels per side of the smallest level (levels halve down to it).",
)
@click.option(
    "--levels",
    type=click.IntRange(2, 16),
    default=5,
    show_default=True,
    help="Prefiltered levels, one per roughness, evenly spaced in --roughness-range.",
)
@click.option(
    "--roughness-range",
    default="0.2:1",
    show_default=True,
    help="Perceptual roughness lo:hi of the first and last level (GGX width α = r²).",
)
@samples_opt(1024, "per prefiltered texel (GGX half vectors, Karis 2013)")
@negative_opt
@fix_nonfinite_opt
@json_opt
@quiet_opt
@deprecated("--top", "size", "--size", type=click.IntRange(8, 2048))
def split_sum(
    env,
    output,
    size,
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
    config = SplitSumConfig(size, min_size, levels, lo, hi, samples)
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
