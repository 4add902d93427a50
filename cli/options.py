"""Options and parameter types shared by the subcommands (``docs/CLI.md``), and output helpers.

Every command takes its common options from here so that one word means one
thing everywhere: ``-o/--output`` is a file, ``--out-dir``/``--exr-dir`` are
folders, ``--size``, ``--samples`` and ``--tol`` are the one name of an image
size, a sample count and a tolerance, ``--roughness`` is perceptual and
``--alpha`` the GGX width. Old spellings are :func:`deprecated` hidden aliases.
"""

import functools
import os
import shlex
import sys
from contextlib import contextmanager

import click
import numpy as np

from shbake.conventions import DISPLAY_TRANSFORMS, SAMPLES_LIMIT, perceptual_roughness
from shbake.envmap.layouts import LAYOUTS
from shbake.envmap.repair import NEGATIVE_POLICIES, NONFINITE_REPAIRS
from shbake.errors import OutputError, ParameterError
from shbake.messages import printable, record, run_warnings
from shbake.progress import Progress


class FiniteRange(click.FloatRange):
    """``click.FloatRange`` that also refuses NaN (every comparison with NaN is false, so
    click's range check lets it through) and, without bounds, infinities."""

    def convert(self, value, param, ctx):
        rv = super().convert(value, param, ctx)
        if not np.isfinite(rv):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return rv


class _Finite(click.types.FloatParamType):
    def convert(self, value, param, ctx):
        rv = super().convert(value, param, ctx)
        if not np.isfinite(rv):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return rv


FINITE = _Finite()
"""A finite float option (``type=FINITE`` instead of ``type=float``; shown as FLOAT)."""


@contextmanager
def usage_errors():
    """Run the library's check of a command's settings: its
    :class:`~shbake.errors.ParameterError` (a value outside the range the library allows,
    which may depend on other options; the message names the range) becomes click's usage
    error (exit 2). Only around checks made before any input is read: a parameter an input
    turns out not to support is a bad input (exit 1)."""
    try:
        yield
    except ParameterError as e:
        raise click.UsageError(str(e)) from None


def output_opt(help_text: str, required: bool = True, dir_okay: bool = False):
    """``-o/--output FILE``: the command's main output, a file (``dir_okay``: or a folder
    written whole, ``export --to webgl``)."""
    return click.option(
        "-o",
        "--output",
        required=required,
        type=click.Path(dir_okay=dir_okay, writable=False),
        help=f"{help_text} ({'a file or folder' if dir_okay else 'a file'}; written atomically).",
    )


def many_maps_opts(f):
    """``--list``, ``--out-dir``, ``--jobs``: a command's maps in one call
    (:mod:`shbake.batch.project_many`), as ``probe-fit`` takes them."""
    from shbake.batch.workers import JOBS_LIMIT

    jobs_help = f"Local worker processes for several maps (1…{JOBS_LIMIT})."
    f = click.option("--jobs", "n_jobs", type=click.IntRange(1, JOBS_LIMIT), default=1,
                     show_default=True, help=jobs_help)(f)  # fmt: skip
    f = click.option(
        "--out-dir",
        default=None,
        type=click.Path(file_okay=False),
        help="Several maps: each asset as OUT_DIR/STEM.h5 [default: .].",
    )(f)
    return click.option(
        "--list",
        "map_list",
        type=click.Path(dir_okay=False),
        help="Maps: lines 'MAP [OUTPUT]', relative to the list.",
    )(f)


def many_maps(maps, output, map_list, out_dir, **one_map_only) -> bool:
    """Whether a command runs on many maps (several MAPS, ``--list`` or ``--out-dir``),
    refusing what only one map takes (``-o`` and the options named in ``one_map_only``,
    when set) — or, for one map, a missing ``-o``."""
    if len(maps) == 1 and map_list is None and out_dir is None:  # --jobs: one map, one job
        if output is None:
            raise click.MissingParameter(param_hint="'-o' / '--output'", param_type="option")
        return False
    if not maps and map_list is None:
        raise click.UsageError("give a map, several maps or a --list file")
    given = [k for k, v in {"output": output, **one_map_only}.items() if v]
    if given:
        raise click.UsageError(f"--{given[0].replace('_', '-')} takes one map (several maps: "
                               "--out-dir, --list)")  # fmt: skip
    return True


def run_many_maps(command, maps, map_list, out_dir, n_jobs, settings, as_json, quiet) -> None:
    """Run ``command`` on many maps (:func:`shbake.batch.project_many.run_many`) and report
    them: one line, each map's warnings, ``--json`` the per-map summaries."""
    import time

    from shbake.batch.map_list import map_outputs
    from shbake.batch.project_many import run_many

    pairs = map_outputs(maps, map_list, out_dir or ".")
    t0 = time.perf_counter()
    done = run_many(command, pairs, settings, n_jobs)
    seconds = time.perf_counter() - t0
    for d in done:
        for w in d["warnings"]:
            warn(f"{d['input']}: {w}", quiet)
    info(f"{command}: {len(done)} maps in {seconds:.2f} s", quiet)
    if as_json:
        emit_json({"maps": done, "seconds": seconds})


def exr_dir_opt(help_text: str):
    """``--exr-dir DIR``: companion OpenEXR images go into this folder."""
    return click.option(
        "--exr-dir",
        type=click.Path(file_okay=False),
        default=None,
        help=f"Folder for OpenEXR images: {help_text}.",
    )


def size_opt(default: int, help_text: str, lo: int = 2, hi: int = 4096):
    """``--size N``: pixels or texels per side of the main image the command makes."""
    return click.option(
        "--size",
        type=click.IntRange(lo, hi),
        default=default,
        show_default=True,
        help=f"{help_text}, pixels per side ({lo}…{hi}).",
    )


def samples_opt(default: int | None, help_text: str, lo: int = 16, hi: int = SAMPLES_LIMIT):
    """``--samples N``: quadrature samples per integral; the help says per what."""
    return click.option(
        "--samples",
        type=click.IntRange(lo, hi),
        default=default,
        show_default=default is not None,
        help=f"Quadrature samples {help_text} ({lo}…{hi}).",
    )


def tol_opt(help_text: str):
    """``--tol X``: the cheapest setting whose measured error is at most ``X``."""
    return click.option(
        "--tol",
        type=FiniteRange(0.0, 1.0, min_open=True, max_open=True),
        default=None,
        help=f"Error tolerance in (0, 1): {help_text}.",
    )


json_opt = click.option(
    "--json", "as_json", is_flag=True, help="Print a machine-readable summary on stdout."
)
quiet_opt = click.option(
    "-q", "--quiet", is_flag=True, help="No progress bar, warnings or notes on stderr."
)


def _scheduler_address(ctx, param, value):
    if value is None:
        return None
    from shbake.batch.scheduler import parse_address

    try:
        return parse_address(value)
    except ParameterError as e:
        raise click.BadParameter(str(e), ctx, param) from None


def scheduler_opt(f):
    """``--scheduler ADDRESS`` and ``--connect-timeout SECONDS`` (how long connecting may
    take; only with ``--scheduler``, else a usage error, as ``--tol`` without ``--lights
    auto``): every command that runs on Dask takes both. The command receives
    ``scheduler`` (an address, :func:`shbake.batch.scheduler.parse_address`, or ``None``)
    and ``connect_timeout`` (seconds; :data:`~shbake.batch.scheduler.CONNECT_SECONDS`
    unless given)."""
    from click.core import ParameterSource

    from shbake.batch.scheduler import CONNECT_SECONDS, CONNECT_SECONDS_LIMIT

    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        ctx = click.get_current_context()
        given = ctx.get_parameter_source("connect_timeout") is ParameterSource.COMMANDLINE
        if given and kwargs.get("scheduler") is None:
            raise click.UsageError("--connect-timeout applies to --scheduler only")
        return f(*args, **kwargs)

    wrapper = click.option(
        "--connect-timeout",
        type=FiniteRange(0.0, CONNECT_SECONDS_LIMIT, min_open=True),
        default=CONNECT_SECONDS,
        show_default=True,
        metavar="SECONDS",
        help="With --scheduler: the seconds connecting to it may take before the run is "
        "refused (one line, exit 1).",
    )(wrapper)
    return click.option(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        callback=_scheduler_address,
        help="Run on the Dask scheduler at [tcp|tls|ws|wss://]HOST:PORT (tcp when omitted; "
        "connected before any work).",
    )(wrapper)


report_opt = click.option(
    "--report",
    is_flag=True,
    help="Print what the chosen settings cost and how accurate they are (stderr; in --json).",
)
png_opt = click.option(
    "--png", is_flag=True, help="Also write a tone-mapped PNG beside every EXR image."
)
display_opt = click.option(
    "--display",
    type=click.Choice(DISPLAY_TRANSFORMS),
    default="reinhard",
    show_default=True,
    help="Display transform of the contact sheet and PNGs: Reinhard on luminance (hue kept) "
    "or the ACES filmic curve per channel, as engines show it (Narkowicz's fit).",
)
layout_opt = click.option(
    "--layout",
    type=click.Choice(LAYOUTS),
    default=None,
    help="Input layout; detected from the image shape (and EXR envmap attribute) when omitted.",
)
negative_opt = click.option(
    "--negative",
    type=click.Choice(NEGATIVE_POLICIES),
    default=None,
    help="Negative pixels: clamp to 0 (recorded in the asset; a warning unless given "
    "explicitly), keep, or refuse [default: clamp].",
)
fix_nonfinite_opt = click.option(
    "--fix-nonfinite",
    type=click.Choice(NONFINITE_REPAIRS),
    default=None,
    help="Repair NaN/Inf pixels: black, or the mean of finite 3x3 neighbours "
    "(default: refuse the input).",
)
colorspace_opt = click.option(
    "--colorspace",
    default=None,
    metavar="NAME",
    help="Linear RGB space of the input (e.g. ACEScg, 'ITU-R BT.2020'); converted to Rec.709.",
)


def input_policy_opts(f):
    """``--layout``, ``--negative``, ``--fix-nonfinite``, ``--colorspace``: how a map is read."""
    for opt in (colorspace_opt, fix_nonfinite_opt, negative_opt, layout_opt):
        f = opt(f)
    return f


def roughness_opts(default_roughness: float | None, what: str):
    """``--roughness R`` (perceptual) or ``--alpha A`` (GGX width ``α = r²``), exclusive.

    The command receives ``roughness`` (perceptual, ``None`` if neither was given
    and there is no default).
    """

    def deco(f):
        @functools.wraps(f)
        def wrapper(*args, **kwargs):
            r, a = kwargs.pop("roughness"), kwargs.pop("alpha")
            if r is not None and a is not None:
                raise click.UsageError("give --roughness or --alpha, not both")
            if a is not None:
                r = perceptual_roughness(a)
            kwargs["roughness"] = default_roughness if r is None else r
            return f(*args, **kwargs)

        wrapper = click.option(
            "--alpha",
            type=FiniteRange(0.0, 1.0),
            default=None,
            help=f"{what}: GGX width α (Walter et al. 2007); same as --roughness sqrt(α).",
        )(wrapper)
        default = f" [default: {default_roughness}]" if default_roughness is not None else ""
        return click.option(
            "--roughness",
            type=FiniteRange(0.0, 1.0),
            default=None,
            help=f"{what}: perceptual roughness r (GGX width α = r²){default}.",
        )(wrapper)

    return deco


def deprecated(old: str, target: str, new: str, **option_kwargs):
    """A hidden alias ``old`` of the option whose parameter is ``target`` (spelled ``new``).

    Given on the command line, it warns once on stderr and its value replaces
    the target's. Kept for one release (``docs/CLI.md``).
    """
    dest = "deprecated_" + old.lstrip("-").replace("-", "_")

    def deco(f):
        @functools.wraps(f)
        def wrapper(*args, **kwargs):
            value = kwargs.pop(dest, None)
            if value is not None:
                click.echo(f"shbake: warning: {old} is deprecated; use {new}", err=True)
                kwargs[target] = value
            return f(*args, **kwargs)

        return click.option(old, dest, hidden=True, default=None, **option_kwargs)(wrapper)

    return deco


class SizeHW(click.ParamType):
    """``N`` or ``HxW`` (height × width), each side in ``[lo, hi]``."""

    name = "N|HxW"

    def __init__(self, lo: int = 2, hi: int = 4096):
        self.lo, self.hi = lo, hi

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        try:
            parts = [int(p) for p in str(value).lower().split("x")]
        except ValueError:
            self.fail(f"{value!r}: expected N or HxW", param, ctx)
        if len(parts) == 1:
            parts *= 2
        if len(parts) != 2 or not all(self.lo <= p <= self.hi for p in parts):
            self.fail(f"{value!r}: sides must be in [{self.lo}, {self.hi}]", param, ctx)
        return parts[0], parts[1]


class NameValue(click.ParamType):
    """``NAME=VALUE`` → ``(NAME, VALUE)``: values stay strings (the model parses them), or with
    ``number`` must be finite numbers (``(NAME, float)``)."""

    name = "NAME=VALUE"

    def __init__(self, number: bool = False):
        self.number = number

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        if "=" not in value:
            self.fail(f"{value!r}: expected NAME=VALUE", param, ctx)
        k, v = (part.strip() for part in value.split("=", 1))
        if not self.number:
            return k, v
        try:
            number = float(v)
        except ValueError:
            number = float("nan")
        if not np.isfinite(number):
            self.fail(f"{value!r}: VALUE must be a finite number", param, ctx)
        return k, number


def parse_range(text: str, option: str) -> tuple[float, float]:
    """``"lo:hi"`` → ``(lo, hi)``."""
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise ParameterError(f"{option} {text!r}: expected lo:hi, e.g. 0.2:1") from None
    return lo, hi


def command_line(ctx: click.Context) -> str:
    """The command line as typed (``main`` passes argv), for provenance."""
    argv = (ctx.find_root().obj or {}).get("argv")
    if argv is None:
        argv = sys.argv[1:]
    return shlex.join(["shbake", *argv])


def info(msg: str, quiet: bool = False) -> None:
    """A message for people: one line on stderr, control characters escaped
    (:func:`shbake.messages.printable`: a file name in it cannot act on the terminal)."""
    if not quiet:
        click.echo(printable(msg), err=True)


LISTED_PER_FOLDER = 3
"""A ``wrote`` line names up to this many files of one folder, else the folder and a count."""


def headline_line(error: dict) -> str:
    """A bake's headline error (:func:`shbake.batch.project_env.headline_error`) on one line."""
    return (f"error {error['value']:.2%} (relative RMS of luminance vs brute force) of the "
            f"{error['quantity']}; mean {error['mean']:.2%}, max {error['max']:.2%} "
            "relative")  # fmt: skip


def glossy_line(chain: dict) -> str:
    """A cube chain's report (:func:`shbake.batch.export.export_assets` ``glossy_report``) on
    one line: its settings and cost, then its worst roughness first."""
    errors = sorted(chain["roughness"], key=lambda e: -e["p95"])
    parts = ", ".join(f"r {e['roughness']:g} {e['p95']:.1%} / {e['median']:.1%}" for e in errors)
    return (f"{chain['input']}: glossy chain {chain['size']}² to {chain['floor']}² "
            f"({chain['levels']} levels, {chain['samples']} samples, baked in "
            f"{chain['bake_s']:.1f} s), read as the engine does (lod mapping "
            f"{chain['mapping']}): p95 / median relative error of luminance vs brute force "
            f"{parts}")  # fmt: skip


def also_wrote(paths) -> str:
    """The ``; also …`` tail of a ``wrote MAIN …`` line: every other file the run wrote, by
    name where a folder holds at most :data:`LISTED_PER_FOLDER` of them, else as ``N files in
    FOLDER/``; empty when there is none."""
    folders: dict[str, list[str]] = {}
    for path in paths:
        folders.setdefault(os.path.dirname(path), []).append(path)
    parts = []
    for folder, files in folders.items():
        if len(files) <= LISTED_PER_FOLDER:
            parts += files
        else:
            parts.append(f"{len(files)} files in {os.path.join(folder or '.', '')}")
    return "; also " + ", ".join(parts) if parts else ""


def info_lines(text: str, quiet: bool = False) -> None:
    """A multi-line report (tables): :func:`info` per line."""
    for line in text.splitlines():
        info(line, quiet)


def warn(msg: str, quiet: bool = False) -> None:
    """``shbake: warning: …`` on stderr (not with ``quiet``), and in the run's ``--json``."""
    record(msg)
    info(f"shbake: warning: {msg}", quiet)


class BarProgress(Progress):
    """:class:`shbake.progress.Progress` drawn as tqdm bars on stderr (TTY only, not --quiet)."""

    def __init__(self, quiet: bool = False):
        self.enabled = not quiet and sys.stderr.isatty()

    def _open(self, description, total, unit):
        if not self.enabled:
            return None
        from tqdm import tqdm

        tqdm.monitor_interval = 0  # no monitor thread: nothing of tqdm's outlives the run
        return tqdm(total=total, desc=printable(description), unit=unit, file=sys.stderr,
                    leave=False, dynamic_ncols=True)  # fmt: skip

    def _advance(self, handle, n):
        handle.update(n)

    def _close(self, handle):
        handle.close()


def json_value(o):
    """``o`` with numpy values as Python ones and every non-finite float as ``None``
    (``null``: ``NaN`` and ``Infinity`` are not JSON)."""
    if isinstance(o, dict):
        return {k: json_value(v) for k, v in o.items()}
    if isinstance(o, (list, tuple, np.ndarray)):
        return [json_value(v) for v in (o.tolist() if isinstance(o, np.ndarray) else o)]
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float) and not np.isfinite(o):
        return None
    return o


def emit_json(summary: dict) -> None:
    """The ``--json`` summary: one JSON document on stdout (a non-finite number is
    ``null``). Its ``warnings`` list holds every warning of the run, printed or silenced by
    ``-q``, then any the summary had."""
    import json  # only --json needs it (start-up)

    given = run_warnings()
    summary = summary | {"warnings": given + [w for w in summary.get("warnings", [])
                                              if w not in given]}  # fmt: skip
    try:
        sys.stdout.write(json.dumps(json_value(summary), sort_keys=True, allow_nan=False) + "\n")
        sys.stdout.flush()
    except OSError as e:
        raise OutputError(f"cannot write the JSON summary to stdout ({e.strerror})") from None
