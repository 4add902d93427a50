"""Entry point: the ``shbake`` group, and library errors turned into one-line messages."""

import sys

import click
from shbake_cli.brdf_table import brdf_table
from shbake_cli.export import export
from shbake_cli.guard import guarded_invoke, run
from shbake_cli.overview import overview
from shbake_cli.preview import preview
from shbake_cli.probe_eval import probe_eval
from shbake_cli.probe_fit import probe_fit
from shbake_cli.project_env import project_env
from shbake_cli.split_sum import split_sum

from shbake import __version__
from shbake.resources import end_run, parse_size, set_memory_budget, start_run
from shbake.signals import exit_quietly_on_signal


class ShbakeGroup(click.Group):
    """The command group: each subcommand runs as one output transaction (guard.py)."""

    def invoke(self, ctx):
        return guarded_invoke(lambda: super(ShbakeGroup, self).invoke(ctx))


def _max_memory(ctx, param, value):
    if value is not None:
        set_memory_budget(parse_size(value))
    return value


@click.group(cls=ShbakeGroup, context_settings={"help_option_names": ["-h", "--help"]})
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


cli.add_command(project_env)
cli.add_command(preview)
cli.add_command(brdf_table)
cli.add_command(probe_fit)
cli.add_command(split_sum)
cli.add_command(probe_eval)
cli.add_command(overview)
cli.add_command(export)


def main(argv=None) -> int:
    """Run the CLI; every failure is one line on stderr and a non-zero exit.

    Exit status: 0 success, 1 bad input or failed output, 2 usage error, 130/143
    interrupted by SIGINT/SIGTERM (:mod:`shbake_cli.guard`).
    """
    console = argv is None
    if console:
        argv = sys.argv[1:]
    argv = list(argv)
    set_memory_budget(None)
    start_run()
    try:
        return run(
            lambda: cli.main(
                args=argv, prog_name="shbake", standalone_mode=False, obj={"argv": argv}
            ),
            argv,
        )
    finally:
        end_run()
        if console:
            exit_quietly_on_signal()


if __name__ == "__main__":
    sys.exit(main())
