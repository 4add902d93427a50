"""Entry point: the ``shbake`` group, and library errors turned into one-line messages."""

import sys

import click
from shbake_cli.brdf_table import brdf_table
from shbake_cli.export import export
from shbake_cli.overview import overview
from shbake_cli.plan import bake, plan
from shbake_cli.preview import preview
from shbake_cli.probe_eval import probe_eval
from shbake_cli.probe_fit import probe_fit
from shbake_cli.project_env import project_env
from shbake_cli.split_sum import split_sum
from shbake_cli.tradeoff import tradeoff_cmd

from shbake import __version__
from shbake.errors import ShbakeError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="shbake")
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
cli.add_command(plan)
cli.add_command(bake)
cli.add_command(tradeoff_cmd)


def main(argv=None) -> int:
    """Run the CLI; every error is one line on stderr and a non-zero exit.

    Exit status: 0 success, 1 bad input or failed output (ShbakeError), 2
    usage error (unknown option, invalid choice).
    """
    try:
        if argv is None:
            argv = sys.argv[1:]
        cli.main(args=argv, prog_name="shbake", standalone_mode=False, obj={"argv": list(argv)})
    except click.exceptions.Abort:
        click.echo("shbake: error: aborted", err=True)
        return 1
    except click.exceptions.UsageError as e:
        click.echo(f"shbake: error: {e.format_message()}", err=True)
        return 2
    except click.exceptions.ClickException as e:
        click.echo(f"shbake: error: {e.format_message()}", err=True)
        return 1
    except ShbakeError as e:
        click.echo(f"shbake: error: {e}", err=True)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
