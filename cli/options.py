"""Options shared by several subcommands, and helpers for output."""

import json
import sys

import click
import numpy as np

json_opt = click.option(
    "--json", "as_json", is_flag=True, help="Print a machine-readable summary on stdout."
)
quiet_opt = click.option("-q", "--quiet", is_flag=True, help="No warnings or progress on stderr.")
lmax_opt = click.option(
    "--lmax",
    type=int,
    default=2,
    show_default=True,
    help="Highest SH band l (0…128); (lmax+1)^2 coefficients.",
)
layout_opt = click.option(
    "--layout",
    type=click.Choice(["latlong", "cube-strip", "cross-h", "cross-v"]),
    default=None,
    help="Input layout; detected from the image shape when omitted.",
)
negative_opt = click.option(
    "--negative",
    type=click.Choice(["clamp", "keep", "error"]),
    default="clamp",
    show_default=True,
    help="Negative pixels: clamp to 0 (warn, recorded in the asset), keep, or refuse.",
)
fix_nonfinite_opt = click.option(
    "--fix-nonfinite",
    type=click.Choice(["black", "box3"]),
    default=None,
    help="Repair NaN/Inf pixels (default: refuse the input).",
)
colorspace_opt = click.option(
    "--colorspace",
    default=None,
    metavar="NAME",
    help="Linear RGB space of the input (e.g. ACEScg, 'ITU-R BT.2020'); converted to Rec.709.",
)


def info(msg: str, quiet: bool = False) -> None:
    """A message for people: stderr."""
    if not quiet:
        click.echo(msg, err=True)


def _default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o))


def emit_json(summary: dict) -> None:
    """The ``--json`` summary: one JSON document on stdout."""
    sys.stdout.write(json.dumps(summary, sort_keys=True, default=_default) + "\n")
