"""``shbake plan`` and ``shbake bake``: a scene's assets, their settings, and baking them."""

from contextlib import contextmanager

import click
from shbake_cli.options import (
    emit_json,
    info,
    info_lines,
    json_opt,
    quiet_opt,
    scheduler_opt,
    warn,
)

from shbake.batch.makefile import MakeNameError
from shbake.batch.plan import format_plan, plan_scene_kept
from shbake.batch.scene import SceneError, load_scene
from shbake.batch.scene_bake import bake_scene, check_makeable, emit_make, format_bake
from shbake.format.atomic import check_output_path
from shbake.messages import printable

allow_outside_opt = click.option(
    "--allow-outside", is_flag=True,
    help="Let the scene's out_dir be outside its folder (absolute, or with '..').",
)  # fmt: skip


@contextmanager
def scene_errors():
    """A malformed scene (:class:`SceneError`, ``FILE:LINE: KEY: …``) or a name a Makefile
    cannot hold (:class:`MakeNameError`) becomes click's usage error (exit 2); any other
    library error stays what it is (a bad input: exit 1)."""
    try:
        yield
    except (SceneError, MakeNameError) as e:
        raise click.UsageError(str(e)) from None


@click.command("plan")
@click.argument("scene", type=click.Path(dir_okay=False))
@click.option("--emit-make", "emit", type=click.Path(dir_okay=False), default=None,
              help="Also write a Makefile fragment (one rule per asset) to this file.")
@click.option("--shbake", "shbake_cmd", default="shbake", show_default=True,
              help="How the fragment's rules call shbake (overridable as $(SHBAKE)).")
@click.option("--maps-per-rule", type=click.IntRange(1, 1024), default=1, show_default=True,
              help="Fragment rules bake the assets of this many maps in one process (GNU "
              "make 4.3 grouped targets); each rule rebakes only its out-of-date assets.")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="Worker processes measuring the maps' plans (8 maps a task).")
@allow_outside_opt
@json_opt
@quiet_opt
def plan(scene, emit, shbake_cmd, maps_per_rule, jobs, allow_outside, as_json, quiet):
    """Decide which assets SCENE (a TOML scene file) needs and at which settings.

    Prints asset, settings, predicted error (tolerance), predicted seconds and
    bytes per asset; a malformed scene is one line FILE:LINE: KEY: … (exit 2).
    """
    with scene_errors():
        sc = load_scene(scene, allow_outside)
        if emit:  # before planning: names a Makefile cannot hold, an unwritable fragment
            check_makeable(sc, emit, shbake_cmd)
            check_output_path(emit, "--emit-make")
        result = plan_scene_kept(sc, jobs=jobs)
        if emit:
            emit_make(sc, result, emit, shbake_cmd, maps_per_rule)
    if emit:
        info(f"plan: wrote {emit} ({len(result['assets'])} rules)", quiet)
    if as_json:
        emit_json(result)
    elif not quiet:
        click.echo("\n".join(map(printable, format_plan(result).splitlines())))


@click.command("bake")
@click.argument("scene", type=click.Path(dir_okay=False))
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="Local worker processes.")
@scheduler_opt
@click.option("--asset", "only", multiple=True, metavar="ID",
              help="Bake only this asset from its settings stamp (what make rules run); "
              "repeated: those of them out of date by make's rule.")
@allow_outside_opt
@json_opt
@quiet_opt
def bake(scene, jobs, scheduler, connect_timeout, only, allow_outside, as_json, quiet):
    """Bake what SCENE needs and is out of date (scene.lock.json in the scene's out_dir).

    With --scheduler the assets are baked on Dask workers and written here, with the
    lock, all together or not at all; a scheduler that does not answer within
    --connect-timeout seconds is one line (exit 1), before anything is planned.
    """
    if scheduler and jobs != 1:
        raise click.UsageError("use --jobs or --scheduler, not both")
    if scheduler and only:
        raise click.UsageError("--asset bakes one asset in this process: no --scheduler")
    with scene_errors():
        summary = bake_scene(load_scene(scene, allow_outside), jobs=jobs, scheduler=scheduler,
                             only=list(only) or None,
                             connect_timeout=connect_timeout)  # fmt: skip
    for w in summary["warnings"]:
        warn(w, quiet)
    if as_json:
        emit_json(summary)
    else:
        info_lines(format_bake(summary), quiet)
