"""Entry point: the ``shbake`` group, and every failure turned into one line and an exit status.

Start-up (issue 15): a subcommand's module is imported only when that
subcommand runs (``shbake project-env`` never imports the preview or the BRDF
code), and a console-script run ends with ``os._exit`` once its outputs are
closed, skipping the interpreter's teardown of numba, h5py and OpenImageIO. The cyclic
garbage collector is paused while the subcommand's modules load (they create ~100 000
long-lived objects and no garbage: 6-8 ms of collections in ``project-env``), then what
they created is frozen out of its scans and it runs again.

Failures (issue 11): each subcommand runs as one output transaction, under the
signal handlers, with errors mapped to one line by :mod:`shbake_cli.guard`.
"""

import gc
import importlib
import os
import sys

import click
from shbake_cli.guard import guarded_invoke, replace_closed_streams, run

from shbake import __version__, messages
from shbake.errors import ParameterError
from shbake.resources import end_run, parse_size, set_memory_budget, start_run
from shbake.signals import exit_quietly_on_signal, ignored_during_teardown

COMMANDS = {
    "project-env": "project_env:project_env",
    "preview": "preview:preview",
    "brdf-table": "brdf_table:brdf_table",
    "probe-fit": "probe_fit:probe_fit",
    "split-sum": "split_sum:split_sum",
    "probe-eval": "probe_eval:probe_eval",
    "overview": "overview:overview",
    "export": "export:export",
    "shrm": "shrm:shrm",
    "plan": "plan:plan",
    "bake": "plan:bake",
    "tradeoff": "tradeoff:tradeoff_cmd",
}
"""Subcommand → ``module:attribute`` in ``shbake_cli``, imported on use."""


class LazyGroup(click.Group):
    """A click group that imports a subcommand's module only when it is needed, and runs
    each subcommand as one output transaction (:func:`shbake_cli.guard.guarded_invoke`)."""

    def list_commands(self, ctx):
        return list(COMMANDS)

    def get_command(self, ctx, name):
        target = COMMANDS.get(name)
        if target is None:
            return None
        module, attr = target.split(":")
        command = getattr(importlib.import_module(f"shbake_cli.{module}"), attr)
        _end_start_up()
        return command

    def invoke(self, ctx):
        return guarded_invoke(lambda: super(LazyGroup, self).invoke(ctx))


def _max_memory(ctx, param, value):
    if value is not None:
        try:
            set_memory_budget(parse_size(value))
        except ParameterError as e:
            raise click.BadParameter(str(e), ctx, param) from None
    return value


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="shbake")
@click.option(
    "--max-memory",
    metavar="SIZE",
    default=None,
    expose_value=False,
    callback=_max_memory,
    help="Memory budget (e.g. 4G): runs whose estimate is larger are refused "
    "[default: $SHBAKE_MAX_MEMORY, else 80% of the available memory].",
)
def cli():
    """Bake spherical-harmonic lighting assets for real-time renderers."""


def main(argv=None) -> int:
    """Run the CLI; every failure is one line on stderr and a non-zero exit.

    Exit status: 0 success, 1 bad input or failed output, 2 usage error, 130/143
    interrupted by SIGINT/SIGTERM (:mod:`shbake_cli.guard`).
    """
    script = argv is None
    if script:
        argv = sys.argv[1:]
        replace_closed_streams()
    argv = list(argv)
    set_memory_budget(None)
    start_run()
    if script:
        _pause_collector_for_start_up()
    try:
        code = run(
            lambda: cli.main(
                args=argv, prog_name="shbake", standalone_mode=False, obj={"argv": argv}
            ),
            argv,
        )
    finally:
        _end_start_up()
        end_run()
        messages.end_run()
        set_memory_budget(None)  # --max-memory is this run's, not the process's
        if script:
            workers = sys.modules.get("shbake.batch.workers")  # imported by --jobs runs
            if workers is not None:
                ignored_during_teardown()
                workers.stop_server()
            exit_quietly_on_signal()
    if script:
        _fast_exit(code)
    return code


_start_up = False


def _pause_collector_for_start_up() -> None:
    global _start_up
    _start_up = True
    gc.disable()


def _end_start_up() -> None:
    """After a console-script run's imports: freeze what they created (never collected,
    never scanned again) and let the collector run."""
    global _start_up
    if _start_up:
        _start_up = False
        gc.freeze()
        gc.enable()


def _fast_exit(code: int) -> None:
    """End a console-script run without interpreter teardown, whatever threads are alive.

    By now the run's transaction is committed or aborted, every HDF5 file it wrote is
    closed (writers close before committing), pool workers are joined or terminated
    (they also die with this process, ``PR_SET_PDEATHSIG``) and a Dask client is closed.
    What is left is other libraries' threads (tqdm's monitor, Dask's event loop) and
    their finalisers, which print after shbake's last line (nanobind's leak report,
    ``Task exception was never retrieved``): stdout and stderr are flushed and the
    process ends here.
    """
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


if __name__ == "__main__":
    sys.exit(main())
