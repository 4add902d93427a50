"""``probe-fit`` as one library call: maps (or a map list) → SH-exp probes, in batch.

Outputs: one ``shexp_probe`` file per map into ``out_dir`` (or the list's
named outputs), or all probes in one ``shexp_probe_set`` file (``output``),
written only when every probe succeeded. ``report``/``tol`` study the first
map (:mod:`shbake.bakers.shexp_report`) before the batch.
"""

import os
import time
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path

from shbake.bakers.shexp import FitConfig
from shbake.batch.map_list import map_entries, map_outputs
from shbake.batch.probe_jobs import ProbeJob, fit_plan, run_dask, run_local, shared_dfg_table
from shbake.batch.scheduler import CONNECT_SECONDS, session
from shbake.errors import InputError, OutputError, ParameterError
from shbake.evaluation.metrics import HEADLINE_WARNING
from shbake.format.atomic import check_output_path
from shbake.resources import path_arguments


def make_jobs(maps, probe_list, out_dir, config, negative, fix_nonfinite, output=None):
    """One :class:`ProbeJob` per map (:func:`~shbake.batch.map_list.map_outputs`); with
    ``output`` (a set file) the jobs write nothing."""
    if output is not None:
        entries = map_entries(maps, probe_list)
        check_output_path(output, "-o/--output")
        return [ProbeJob(os.path.abspath(src), None, config, negative, fix_nonfinite)
                for src, _ in entries]  # fmt: skip
    return [ProbeJob(src, out, config, negative, fix_nonfinite)
            for src, out in map_outputs(maps, probe_list, out_dir)]  # fmt: skip


def settings_study(job: ProbeJob, config: FitConfig, report: bool, tol):
    """``tol`` and ``report`` on the first map: (config to use, study, report text)."""
    from shbake.bakers.shexp_report import (
        alpha_rows,
        format_report,
        orders_study,
        pick_samples,
        samples_study,
    )
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
    text = None
    if report:
        plan = fit_plan(config, env.shape)
        e0 = plan.targets.e0(env.pixels)
        study["orders_study"] = orders_study(env.pixels, config, e0)
        study["alpha_study"] = alpha_rows(config, plan.fit_targets(e0).stats)
        text = format_report(samples_rows, study["orders_study"], study["alpha_study"])
    return config, study, text


def write_set(path: str, results: list[dict], config: FitConfig) -> list[dict]:
    """Write the probes of ``results`` as one set asset; return the summaries without arrays."""
    from shbake.format.asset import write_asset
    from shbake.format.shexp import build_shexp_set_asset

    probes = [r | {"name": Path(r["source"]).stem} for r in results]
    write_asset(path, build_shexp_set_asset(probes, config, shared_dfg_table()))
    return [{k: r[k] for k in ("source", "bytes", "error")} | r["stats"] | {"output": path}
            for r in results]  # fmt: skip


DEFAULT_CONFIG = FitConfig()
FIT_ERROR_WARNING = HEADLINE_WARNING["shexp_probe"]
"""Headline error of a probe (the relative RMS of luminance of its shading against brute
force, :func:`shbake.evaluation.probes.glossy_error`) above which probe-fit warns."""


def fit_warnings(results: list[dict]) -> list[str]:
    """Plain-language warnings about probes that shade far from brute force, with what
    lowers their error (studio.exr, 21.4 %: --sets 3 20.8 %, --alpha-range 0.36:1 18.0 %)."""
    errors = [(r["error"]["value"], r.get("source", "?")) for r in results if "error" in r]
    bad = [(e, s) for e, s in errors if e > FIT_ERROR_WARNING]
    if not bad:
        return []
    worst, where = max(bad)
    return [f"{len(bad)} of {len(results)} probes shade with an error above "
            f"{FIT_ERROR_WARNING:.0%} (relative RMS of luminance vs brute force; worst "
            f"{worst:.0%}, {where}): sharp lobes or compact lights; try --sets 3, a narrower "
            "--alpha-range, or split-sum / shrm for low α"]  # fmt: skip


def check_manifest_path(manifest: str, jobs, output) -> None:
    """Refuse, before any work, a ``--manifest`` that cannot be written or that is a map or
    an output of the run (the same file through links or another spelling): it is written
    even when the run fails, so it must not replace what the run reads or writes."""
    check_output_path(manifest, "--manifest")
    here = os.path.abspath(manifest)
    for path in {p for job in jobs for p in (job.source, output or job.output) if p}:
        there = os.path.abspath(path)
        if here == there or (os.path.exists(here) and os.path.exists(there)
                             and os.path.samefile(here, there)):  # fmt: skip
            raise OutputError(f"{manifest}: is also {path} of this run (--manifest must name "
                              "another file)")  # fmt: skip


def write_manifest(path: str, jobs, finished: list, output, error) -> None:
    """``--manifest``: one JSON line per job — source, output, ``written`` / ``not written``
    and the output's SHA-256 — plus the run's status, written atomically on its own even
    when the run failed (so ``make`` or a Dask rerun can resume from it). With ``-o`` (a
    set) the probes are written together or not at all, and a manifest of a run that
    succeeded is committed with the set (its SHA-256 is the staged set's)."""
    import hashlib
    import json

    from shbake.format.atomic import detached, staged, write_text

    def sha256_of(path):  # an output of this run (staged or committed), not read as an input
        return hashlib.sha256(Path(staged(path) or path).read_bytes()).hexdigest()

    done = {r["source"] for r in finished if r.get("output")} if output is None else set()
    set_written = output is not None and error is None
    rows = []
    for job in jobs:
        target = output if output is not None else job.output
        ok = set_written or job.source in done
        rows.append({"source": job.source, "output": target,
                     "status": "written" if ok else "not written",
                     "sha256": sha256_of(target) if ok else None})  # fmt: skip
    reason = (str(error).splitlines() or [type(error).__name__])[0] if error else ""
    status = "ok" if error is None else f"failed: {reason}"
    doc = {"status": status, "probes": rows}
    with nullcontext() if set_written else detached():
        write_text(path, json.dumps(doc, indent=1, sort_keys=True) + "\n")


@path_arguments("maps", "probe_list", "output", "out_dir", "manifest")
def fit_probes(maps, probe_list=None, output=None, out_dir=".", config=DEFAULT_CONFIG,
               negative="clamp", fix_nonfinite=None, report=False, tol=None, n_jobs=1,
               scheduler=None, progress=None, notes=None, manifest=None,
               connect_timeout=CONNECT_SECONDS) -> dict:  # fmt: skip
    """Fit SH-exp probes to ``maps`` (and the lines of ``probe_list``); the summary
    ``{"probes", "seconds", "probes_per_second", "config", …study}``. ``notes(text)``
    receives the ``--tol`` choice and the ``--report`` tables. ``scheduler`` (a Dask
    address or client) is connected before any other work, within ``connect_timeout``
    seconds (:func:`shbake.batch.scheduler.session`)."""
    if scheduler and n_jobs != 1:
        raise ParameterError("use --jobs or --scheduler, not both")
    with session(scheduler, connect_timeout) if scheduler else nullcontext() as client:
        return _fit_probes(maps, probe_list, output, out_dir, config, negative, fix_nonfinite,
                           report, tol, n_jobs, client, progress, notes, manifest)  # fmt: skip


def _fit_probes(maps, probe_list, output, out_dir, config, negative, fix_nonfinite, report, tol,
                n_jobs, client, progress, notes, manifest) -> dict:  # fmt: skip
    jobs = make_jobs(maps, probe_list, out_dir, config, negative, fix_nonfinite, output)
    if manifest is not None:
        check_manifest_path(manifest, jobs, output)
    study = {}
    if report or tol is not None:
        config, study, text = settings_study(jobs[0], config, report, tol)
        jobs = [replace(job, config=config) for job in jobs]
        if notes and tol is not None:
            notes(f"probe-fit: --tol {tol:g} → --samples {config.samples}")
        if notes and text:
            notes(text)
    t0 = time.perf_counter()
    finished: list = []
    error = None
    try:
        if client is not None:
            results = run_dask(jobs, client, progress, finished)
        else:
            results = run_local(jobs, n_jobs, progress, finished)
        if output:
            results = write_set(output, results, config)
    except BaseException as e:
        error = e
        raise
    finally:
        if manifest is not None:
            write_manifest(manifest, jobs, finished, output, error)
    seconds = time.perf_counter() - t0
    rate = len(jobs) / seconds if seconds > 0 else float("inf")
    return {"probes": results, "seconds": seconds, "probes_per_second": rate,
            "config": config.as_dict(), "warnings": fit_warnings(results), **study}  # fmt: skip
