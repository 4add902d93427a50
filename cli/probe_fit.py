"""``shbake probe-fit``: lat-long maps → SH-exponential glossy probes (v2), in batch."""

import sys

import click
from shbake_cli.options import (
    FINITE,
    deprecated,
    emit_json,
    fix_nonfinite_opt,
    info,
    info_lines,
    json_opt,
    negative_opt,
    output_opt,
    parse_range,
    quiet_opt,
    report_opt,
    samples_opt,
    scheduler_opt,
    tol_opt,
    usage_errors,
    warn,
)

from shbake.bakers.shexp import ALPHA_WEIGHT_LIMIT, FIT_TARGETS, SETS_LIMIT, WEIGHTS, FitConfig
from shbake.batch.probe_fit import fit_probes
from shbake.batch.workers import JOBS_LIMIT
from shbake.conventions import SH_TARGETS_LMAX_LIMIT, SHEXP_LMAX_LIMIT, ggx_alpha
from shbake.errors import ParameterError

DEFAULT = FitConfig()


def fit_alpha_range(alpha_text, roughness_text) -> tuple[float, float]:
    """The fit's GGX-width range from ``--alpha-range`` or ``--roughness-range`` (``α = r²``)."""
    if alpha_text is not None and roughness_text is not None:
        raise click.UsageError("give --alpha-range or --roughness-range, not both")
    if roughness_text is not None:
        lo, hi = parse_range(roughness_text, "--roughness-range")
        return ggx_alpha(lo), ggx_alpha(hi)
    return parse_range(alpha_text or "0.2:1", "--alpha-range")


@click.command("probe-fit")
@click.argument("maps", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--list", "probe_list", type=click.Path(dir_okay=False),
              help="Probe list: lines 'MAP [OUTPUT]'.")  # fmt: skip
@output_opt("All probes in one shexp_probe_set asset, list order, written only if all succeed",
            required=False)  # fmt: skip
@click.option("--out-dir", default=".", show_default=True, type=click.Path(file_okay=False),
              help="Without -o: one <map stem>.h5 probe per map into this folder.")  # fmt: skip
@click.option("--lmax-p", type=click.IntRange(0, SHEXP_LMAX_LIMIT), default=DEFAULT.lmax_p,
              show_default=True,
              help=f"Highest band of P (mirror direction), 0…{SHEXP_LMAX_LIMIT}.")  # fmt: skip
@click.option("--lmax-q", type=click.IntRange(1, SHEXP_LMAX_LIMIT), default=2, show_default=True,
              help=f"Highest band of Q (half-reflection, DC dropped), 1…{SHEXP_LMAX_LIMIT}."
              )  # fmt: skip
@click.option("--normals", type=int, default=DEFAULT.normals, show_default=True,
              help="Fit normals (Fibonacci sphere).")  # fmt: skip
@click.option("--views", type=int, default=32, show_default=True,
              help="Fit views per normal (uniform on the hemisphere; weighted 2 n·v by "
              "shaded-nv: the on-screen, cosine-weighted distribution).")  # fmt: skip
@click.option("--alpha-range", default=None, metavar="LO:HI",
              help="GGX-width range of the fit [default: 0.2:1]; the probe shades only it.")
@click.option("--roughness-range", default=None, metavar="LO:HI",
              help="The same range as perceptual roughness (α = r²); exclusive with "
              "--alpha-range.")  # fmt: skip
@click.option("--alpha-count", type=int, default=8, show_default=True,
              help="Fit α values, evenly spaced over the range (at least 2·sets − 1).")
@click.option("--sets", type=click.IntRange(1, SETS_LIMIT), default=2, show_default=True,
              help="Coefficient sets K, hat-blended (linear) in α; 1 with --weights log, "
              "--alpha-weight 0 and --alpha-count 4 is the paper's model.")  # fmt: skip
@click.option("--weights", type=click.Choice(WEIGHTS), default="shaded-nv", show_default=True,
              help="Log-space sample weights: log (eq. 13), shaded (E0²), shaded-nv "
              "(E0² · 2 n·v), shaded-nv-f0 (+ chrome/dielectric balance).")  # fmt: skip
@click.option("--polish", type=click.IntRange(0, 8), default=DEFAULT.polish, show_default=True,
              help="Gauss–Newton steps on the shaded error after the log fit (shaded-nv*; "
              "a step that does not lower it is dropped).")  # fmt: skip
@click.option("--alpha-weight", type=click.FloatRange(0, ALPHA_WEIGHT_LIMIT),
              default=DEFAULT.alpha_weight, show_default=True,
              help="Exponent s of the (α_min/α)^s factor on every fit sample's weight: s = 1 "
              "weighs a sample by 1/α (the narrow end, where split-sum is nearly exact); 0: "
              "none.")  # fmt: skip
@samples_opt(1024, "per E0 fit target (filtered visible-normal samples)")
@click.option("--floor", type=FINITE, default=1e-4, show_default=True,
              help="E0 floor before the log, × mean E0 per channel.")  # fmt: skip
@click.option("--targets", type=click.Choice(FIT_TARGETS), default="quadrature", show_default=True,
              help="E0 at the fit samples: quadrature (filtered importance sampling) or sh "
              "(SH lighting x GGX tables; noise-free, blurs narrow lobes).")  # fmt: skip
@click.option("--targets-lmax", type=click.IntRange(1, SH_TARGETS_LMAX_LIMIT), default=8,
              show_default=True,
              help=f"Lighting bands of --targets sh, 1…{SH_TARGETS_LMAX_LIMIT}.")  # fmt: skip
@report_opt
@tol_opt("the fewest --samples (256-4096, and --samples itself) whose E0 target error (log RMS, "
         "first map) is at most this")  # fmt: skip
@click.option("--jobs", "n_jobs", type=click.IntRange(1, JOBS_LIMIT), default=1,
              show_default=True,
              help=f"Local worker processes (1…{JOBS_LIMIT}: four per CPU).")  # fmt: skip
@scheduler_opt
@click.option("--manifest", type=click.Path(dir_okay=False), default=None,
              help="JSON file listing every probe as written or not (with its SHA-256) and "
              "the run's status; written even when the batch fails, so a rerun can resume "
              "(a file).")  # fmt: skip
@deprecated("--set", "output", "-o/--output", type=click.Path(dir_okay=False))
@deprecated("--roughness-count", "alpha_count", "--alpha-count", type=int)
@negative_opt
@fix_nonfinite_opt
@json_opt
@quiet_opt
def probe_fit(maps, probe_list, output, out_dir, alpha_range, roughness_range, alpha_count,
              as_json, quiet, **settings):  # fmt: skip
    """Fit SH-exp v2 probes (2 × 44 numbers per channel by default) to MAPS.

    α is the GGX width (SPEC §1). Each probe is one atomic, idempotent file
    (or one set file with -o); the same inputs give byte-identical files
    with --jobs, --scheduler or neither.
    """
    run = {k: settings.pop(k) for k in ("negative", "fix_nonfinite", "report", "tol", "n_jobs",
                                        "scheduler", "connect_timeout", "manifest")}  # fmt: skip
    if output and probe_list is None and not maps:
        raise ParameterError("give maps as arguments or a --list file")
    if run["scheduler"] and run["n_jobs"] != 1:
        raise click.UsageError("use --jobs or --scheduler, not both")
    with usage_errors():
        lo, hi = fit_alpha_range(alpha_range, roughness_range)
        config = FitConfig(alpha_count=alpha_count, alpha_min=lo, alpha_max=hi, **settings)
    show = not quiet and sys.stderr.isatty()

    def progress(done, total):
        if show:
            click.echo(f"\rprobe-fit: {done}/{total}", err=True, nl=done == total)

    summary = fit_probes(maps, probe_list, output, out_dir, config, progress=progress,
                         notes=lambda text: info_lines(text, quiet), **run)  # fmt: skip
    for probe in summary["probes"]:
        e = probe["error"]
        info(f"{probe['source']}: error {e['value']:.2%} (relative RMS of luminance vs brute "
             f"force) of the {e['quantity']}", quiet)  # fmt: skip
    for w in summary["warnings"]:
        warn(w, quiet)
    info(f"probe-fit: {len(summary['probes'])} probes in {summary['seconds']:.2f} s "
         f"({summary['probes_per_second']:.1f} probes/s)", quiet)  # fmt: skip
    if as_json:
        emit_json(summary)
