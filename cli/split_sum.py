"""``shbake split-sum``: the split-sum baseline probe (prefiltered octahedral mip chain + DFG)."""

import click
from shbake_cli.options import (
    deprecated,
    emit_json,
    fix_nonfinite_opt,
    info,
    json_opt,
    many_maps,
    many_maps_opts,
    negative_opt,
    output_opt,
    quiet_opt,
    run_many_maps,
    samples_opt,
    size_opt,
    usage_errors,
)

from shbake.bakers.splitsum import (
    LEVEL_SIZE_MAX,
    LEVEL_SIZE_MIN,
    PAPER_ALPHAS,
    PREFILTERS,
    SplitSumConfig,
)
from shbake.batch.probe_eval import bake_splitsum_file
from shbake.conventions import ggx_alpha
from shbake.errors import ParameterError


def parse_levels(alphas: str | None, roughness: str | None) -> tuple[float, ...]:
    """Level GGX widths from ``--alphas a,b,…`` or ``--roughness-levels r,s,…`` (``α = r²``)."""
    if alphas is not None and roughness is not None:
        raise click.UsageError("give --alphas or --roughness-levels, not both")
    text = alphas if alphas is not None else roughness
    if text is None:
        return PAPER_ALPHAS
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise ParameterError(f"{text!r}: expected comma-separated numbers") from None
    return values if alphas is not None else tuple(ggx_alpha(v) for v in values)


@click.command("split-sum")
@click.argument("maps", nargs=-1, type=click.Path(dir_okay=False))
@output_opt("The splitsum_probe asset (.h5) of one map", required=False)
@many_maps_opts
@size_opt(128, "Texels per side of the first (sharpest) octahedral level", lo=LEVEL_SIZE_MIN,
          hi=LEVEL_SIZE_MAX)  # fmt: skip
@click.option("--min-size", type=click.IntRange(LEVEL_SIZE_MIN, LEVEL_SIZE_MAX), default=32,
              show_default=True, help="Smallest level size (at most --size).")  # fmt: skip
@click.option("--alphas", default=None, metavar="A,B,…",
              help="GGX width of each level, increasing [default: the evaluation's "
              "0.25,0.36,0.49,0.64,0.81,1].")  # fmt: skip
@click.option("--roughness-levels", default=None, metavar="R,S,…",
              help="The levels as perceptual roughness (α = r²); exclusive with --alphas.")
@click.option("--prefilter", type=click.Choice(PREFILTERS), default="plain", show_default=True,
              help="plain: one map texel per sample (Karis; the paper's baseline); filtered: "
              "filtered importance sampling of the solid-angle pyramid (engine-grade).")
@samples_opt(1024, "per texel (GGX half vectors)")
@deprecated("--top", "size", "--size", type=click.IntRange(LEVEL_SIZE_MIN, LEVEL_SIZE_MAX))
@negative_opt
@fix_nonfinite_opt
@json_opt
@quiet_opt
def split_sum(maps, output, map_list, out_dir, n_jobs, size, min_size, alphas,
              roughness_levels, prefilter, samples, negative, fix_nonfinite, as_json,
              quiet):  # fmt: skip
    """Bake the split-sum baseline of MAPS (Karis 2013) as a probe asset of its own; several
    MAPS (or --list, --out-dir): each to OUT_DIR/STEM.h5, in one process or --jobs workers."""
    with usage_errors():
        config = SplitSumConfig(size, min_size, parse_levels(alphas, roughness_levels), samples,
                                prefilter)  # fmt: skip
    if many_maps(maps, output, map_list, out_dir):
        settings = {"config": config, "negative": negative, "fix_nonfinite": fix_nonfinite}
        run_many_maps("split-sum", maps, map_list, out_dir, n_jobs, settings, as_json, quiet)
        return
    summary = bake_splitsum_file(maps[0], output, config, negative, fix_nonfinite)
    info(f"split-sum: {output}: {summary['levels']} levels, {summary['bytes']} bytes", quiet)
    if as_json:
        emit_json(summary)
