"""``shbake overview``: one HTML page that judges a folder of bakes, previews and scene locks
(what ``make demo`` opens with)."""

import click
from shbake_cli.options import emit_json, info, json_opt, output_opt, quiet_opt, tol_opt

from shbake.batch.overview import DEFAULT_TOLERANCE, write_overview
from shbake.evaluation.metrics import HEADLINE_WARNING


@click.command("overview")
@click.argument("folder", type=click.Path(file_okay=False))
@output_opt("The HTML page (e.g. FOLDER/index.html)")
@click.option("--title", default="shbake previews", show_default=True, help="Page title.")
@tol_opt(f"relative error an error is judged against where its summary names no tolerance "
         f"(a scene lock's are its own) [default: the limit at which the command baking it "
         f"warns ({', '.join(f'{k} {v:g}' for k, v in HEADLINE_WARNING.items())}), "
         f"else {DEFAULT_TOLERANCE:g}]")  # fmt: skip
@json_opt
@quiet_opt
def overview(folder, output, title, tol, as_json, quiet):
    """Write an HTML overview of FOLDER: a summary table of every error against its tolerance
    (pass/fail, bytes, bake seconds) first, then the tradeoff plots and the contact sheets.

    FOLDER holds 'shbake preview ... --json > NAME.json', bake summaries ('project-env ...
    --json > NAME.json'), tradeoff*.png, and scene.lock.json (in FOLDER or a folder in it).
    """
    summary = write_overview(folder, output, title, tol)
    if as_json:
        emit_json(summary)
    else:
        failed = f", {summary['failed']} of {summary['rows']} errors over tolerance"
        info(f"wrote {output}: {summary['cards']} previews" + failed, quiet)
