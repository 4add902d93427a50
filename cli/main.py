"""Entry point: the ``shbake`` group, and library errors turned into one-line messages.

Start-up (issue 15): a subcommand's module is imported only when that
subcommand runs (``shbake project-env`` never imports the preview or the BRDF
code), and a console-script run ends with ``os._exit`` once its outputs are
closed, skipping the interpreter's teardown of numba, h5py and OpenImageIO.
"""

import gc
import importlib
import os
import sys
import threading

import click

from shbake import __version__
from shbake.errors import ShbakeError

COMMANDS = {
    "project-env": "project_env:project_env",
    "preview": "preview:preview",
    "brdf-table": "brdf_table:brdf_table",
    "probe-fit": "probe_fit:probe_fit",
    "split-sum": "split_sum:split_sum",
    "probe-eval": "probe_eval:probe_eval",
    "overview": "overview:overview",
    "export": "export:export",
    "plan": "plan:plan",
    "bake": "plan:bake",
    "tradeoff": "tradeoff:tradeoff_cmd",
}
"""Subcommand → ``module:attribute`` in ``shbake_cli``, imported on use."""


class LazyGroup(click.Group):
    """A click group that imports a subcommand's module only when it is needed."""

    def list_commands(self, ctx):
        return list(COMMANDS)

    def get_command(self, ctx, name):
        target = COMMANDS.get(name)
        if target is None:
            return None
        module, attr = target.split(":")
        return getattr(importlib.import_module(f"shbake_cli.{module}"), attr)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="shbake")
def cli():
    """Bake spherical-harmonic lighting assets for real-time renderers."""


def main(argv=None) -> int:
    """Run the CLI; every error is one line on stderr and a non-zero exit.

    Exit status: 0 success, 1 bad input or failed output (ShbakeError), 2
    usage error (unknown option, invalid choice).
    """
    script = argv is None
    try:
        if argv is None:
            argv = sys.argv[1:]
        gc.freeze()  # what is imported so far is never collected: skip scanning it
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
    if script:
        _fast_exit(0)
    return 0


def _fast_exit(code: int) -> None:
    """End a finished console-script run without interpreter teardown (outputs are closed).

    Only when nothing else runs: a single thread and no child processes.
    """
    if threading.active_count() > 1:
        return
    mp = sys.modules.get("multiprocessing")
    if mp is not None and mp.active_children():
        return
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    sys.exit(main())
