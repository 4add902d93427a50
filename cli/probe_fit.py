"""``shbake probe-fit``: lat-long maps → SH-exponential glossy probes, in batch."""

import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import click
from shbake_cli.options import (
    deprecated,
    emit_json,
    fix_nonfinite_opt,
    info,
    json_opt,
    negative_opt,
    parse_range,
    quiet_opt,
)

from shbake.bakers.shexp import TARGETS, WEIGHTINGS, FitConfig
from shbake.batch.probe_jobs import ProbeJob, run_dask, run_local
from shbake.errors import InputError, ParameterError
from shbake.format.atomic import check_output_dir, check_output_path, makedirs
from shbake.resources import read_bounded

PROBE_LIST_MAX_BYTES = 16 << 20
"""Largest probe list read (bytes)."""


def read_probe_list(path: str) -> list[tuple[str, str | None]]:
    """Lines ``MAP [OUTPUT]``; blank lines and ``#`` comments skipped; relative paths
    are relative to the list's folder."""
    base = Path(path).parent
    try:
        raw = read_bounded(path, PROBE_LIST_MAX_BYTES, "probe list (--list)")
        lines = raw.decode("utf-8").splitlines()
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: the probe list is not UTF-8 text (byte {e.start})") from None
    except OSError as e:
        raise InputError(f"{path}: cannot read the probe list ({e.strerror})") from None
    out = []
    for n, line in enumerate(lines, 1):
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        if len(parts) > 2:
            raise InputError(f"{path}:{n}: expected 'MAP [OUTPUT]', got {line.strip()!r}")
        out.append((str(base / parts[0]), str(base / parts[1]) if len(parts) == 2 else None))
    return out


def make_jobs(maps, probe_list, out_dir, config, negative, fix_nonfinite, probe_set=None):
    """One :class:`ProbeJob` per map; with ``probe_set`` the jobs write nothing (a set)."""
    entries = [(m, None) for m in maps] + (read_probe_list(probe_list) if probe_list else [])
    if not entries:
        raise ParameterError("give maps as arguments or a --list file")
    if probe_set is not None:
        check_output_path(probe_set, "-o/--output")
        return [
            ProbeJob(os.path.abspath(src), None, config, negative, fix_nonfinite)
            for src, _ in entries
        ]
    jobs, seen = [], set()
    for src, out in entries:
        if out is None:
            check_output_dir(out_dir, "--out-dir")
            makedirs(out_dir)
            out = os.path.join(out_dir, Path(src).stem + ".h5")
        out = os.path.abspath(out)
        if out in seen:
            raise ParameterError(f"two probes would write {out}; name outputs in a --list file")
        seen.add(out)
        check_output_path(out)
        jobs.append(ProbeJob(os.path.abspath(src), out, config, negative, fix_nonfinite))
    return jobs


def settings_study(job: ProbeJob, config: FitConfig, report: bool, tol, quiet: bool):
    """``--tol`` and ``--report`` on the first map: (config to use, study for the summary)."""
    from shbake.bakers.shexp_report import (
        format_report,
        orders_study,
        pick_samples,
        samples_study,
    )
    from shbake.batch.probe_jobs import fit_plan
    from shbake.envmap import load_environment

    if config.targets != "quadrature":
        raise ParameterError("--report and --tol study the quadrature targets")
    env = load_environment(job.source, negative=job.negative, fix_nonfinite=job.fix_nonfinite,
                           quiet=True)  # fmt: skip
    if env.layout != "latlong":
        raise InputError(f"{job.source}: probe-fit takes lat-long maps (2:1), got {env.layout}")
    samples_rows = samples_study(env.pixels, config)
    study = {"samples_study": samples_rows}
    if tol is not None:
        config = replace(config, samples=pick_samples(samples_rows, tol))
        study["chosen_samples"] = config.samples
        info(f"probe-fit: --tol {tol:g} → --samples {config.samples}", quiet)
    if report:
        e0 = fit_plan(config, env.shape).targets.e0(env.pixels)
        study["orders_study"] = orders_study(env.pixels, config, e0)
        if not quiet:
            click.echo(format_report(samples_rows, study["orders_study"]), err=True)
    return config, study


def write_set(path: str, results: list[dict], config: FitConfig) -> list[dict]:
    """Write the probes of ``results`` as one set asset; return the summaries without arrays."""
    from shbake.batch.probe_jobs import shared_dfg_table
    from shbake.format.asset import write_asset
    from shbake.format.shexp import build_shexp_set_asset

    probes = [r | {"name": Path(r["source"]).stem} for r in results]
    write_asset(path, build_shexp_set_asset(probes, config, shared_dfg_table()))
    keep = ("source", "bytes")
    return [{k: r[k] for k in keep} | r["stats"] | {"output": path} for r in results]


@click.command("probe-fit")
@click.argument("maps", nargs=-1, type=click.Path(dir_okay=False))
@click.option(
    "--list",
    "probe_list",
    type=click.Path(dir_okay=False),
    help="Probe list: lines 'MAP [OUTPUT]'.",
)
@click.option(
    "-o",
    "--output",
    "probe_set",
    type=click.Path(dir_okay=False),
    help="All probes in this one shexp_probe_set asset, list order (a file; written "
    "atomically, all or nothing). Without it: one file per probe in --out-dir.",
)
@click.option(
    "--out-dir",
    default=".",
    show_default=True,
    type=click.Path(file_okay=False),
    help="Folder for one <map stem>.h5 per probe (each written atomically).",
)
@click.option(
    "--lmax-p", type=int, default=4, show_default=True, help="Highest band of P (mirror direction)."
)
@click.option(
    "--lmax-q",
    type=int,
    default=2,
    show_default=True,
    help="Highest band of Q (half-reflection), DC dropped.",
)
@click.option(
    "--normals", type=int, default=64, show_default=True, help="Fit normals (Fibonacci sphere)."
)
@click.option(
    "--views", type=int, default=64, show_default=True, help="Fit views per normal (hemisphere)."
)
@click.option(
    "--roughness-range",
    default="0.2:1",
    show_default=True,
    help="Perceptual roughness range lo:hi of the fit.",
)
@click.option(
    "--roughness-count",
    type=int,
    default=4,
    show_default=True,
    help="Roughness samples in the range.",
)
@click.option(
    "--samples",
    type=click.IntRange(16, 1 << 20),
    default=1024,
    show_default=True,
    help="Quadrature samples per E0 fit target (filtered visible-normal samples).",
)
@click.option(
    "--weighting",
    type=click.Choice(WEIGHTINGS),
    default="log",
    show_default=True,
    help="log: eq. 13; relative: Gauss-Newton on PQ/E0 - 1; linear: on (PQ - E0)/mean E0.",
)
@click.option(
    "--floor",
    type=float,
    default=1e-4,
    show_default=True,
    help="E0 floor before the log, × mean E0 per channel.",
)
@click.option(
    "--targets",
    type=click.Choice(TARGETS),
    default="quadrature",
    show_default=True,
    help="E0 at the fit samples: quadrature (filtered importance sampling) or sh "
    "(SH lighting x GGX tables; noise-free, blurs low roughness).",
)
@click.option(
    "--targets-lmax",
    type=int,
    default=8,
    show_default=True,
    help="Lighting bands of --targets sh.",
)
@click.option(
    "--report",
    is_flag=True,
    help="Measure target error and time vs --samples, and fit residual vs orders, on the "
    "first map.",
)
@click.option(
    "--tol",
    type=click.FloatRange(0.0, 1.0, min_open=True, max_open=True),
    default=None,
    help="Error tolerance in (0, 1): use the fewest --samples (256-4096) whose E0 target "
    "error (log RMS against a converged truth, first map) is at most TOL.",
)
@click.option(
    "--jobs", "n_jobs", type=int, default=1, show_default=True, help="Local worker processes."
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Dask distributed scheduler (tcp://host:port).",
)
@negative_opt
@fix_nonfinite_opt
@json_opt
@quiet_opt
@deprecated("--set", "probe_set", "-o/--output", type=click.Path(dir_okay=False))
def probe_fit(
    maps,
    probe_list,
    probe_set,
    out_dir,
    lmax_p,
    lmax_q,
    normals,
    views,
    roughness_range,
    roughness_count,
    samples,
    weighting,
    floor,
    targets,
    targets_lmax,
    report,
    tol,
    n_jobs,
    scheduler,
    negative,
    fix_nonfinite,
    as_json,
    quiet,
):
    """Fit P/Q SH-exponential probes (33 numbers per channel by default) to MAPS.

    Roughness is perceptual (GGX width = r²). Each probe is one atomic,
    idempotent file; the same inputs give byte-identical files with --jobs,
    --scheduler or neither.
    """
    lo, hi = parse_range(roughness_range, "--roughness-range")
    config = FitConfig(lmax_p, lmax_q, normals, views, roughness_count, lo, hi, samples,
                       weighting, floor, targets, targets_lmax)  # fmt: skip
    jobs = make_jobs(maps, probe_list, out_dir, config, negative, fix_nonfinite, probe_set)
    study = None
    if report or tol is not None:
        config, study = settings_study(jobs[0], config, report, tol, quiet)
        jobs = [replace(job, config=config) for job in jobs]
    if scheduler and n_jobs != 1:
        raise ParameterError("use --jobs or --scheduler, not both")
    show = not quiet and sys.stderr.isatty()

    def progress(done, total):
        if show:
            click.echo(f"\rprobe-fit: {done}/{total}", err=True, nl=done == total)

    t0 = time.perf_counter()
    if scheduler:
        results = run_dask(jobs, scheduler, progress)
    else:
        results = run_local(jobs, n_jobs, progress)
    if probe_set is not None:
        results = write_set(probe_set, results, config)
    seconds = time.perf_counter() - t0
    rate = len(jobs) / seconds if seconds > 0 else float("inf")
    info(f"probe-fit: {len(jobs)} probes in {seconds:.2f} s ({rate:.1f} probes/s)", quiet)
    if as_json:
        emit_json({"probes": results, "seconds": seconds, "probes_per_second": rate,
                   "config": config.as_dict(), **(study or {})})  # fmt: skip
