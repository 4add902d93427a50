"""``shbake overview``: one HTML page over a folder of previews (what ``make demo`` opens with)."""

import click
from shbake_cli.options import emit_json, info, json_opt, output_opt, quiet_opt

from shbake.preview.overview import write_overview


@click.command("overview")
@click.argument("folder", type=click.Path(file_okay=False))
@output_opt("The HTML page (e.g. FOLDER/index.html)")
@click.option("--title", default="shbake previews", show_default=True, help="Page title.")
@json_opt
@quiet_opt
def overview(folder, output, title, as_json, quiet):
    """Write an HTML overview of the contact sheets and errors of the previews in FOLDER.

    FOLDER holds the outputs of 'shbake preview ... --json > NAME.json'.
    """
    summary = write_overview(folder, output, title)
    if as_json:
        emit_json(summary)
    else:
        info(f"wrote {output}: {summary['cards']} previews", quiet)
