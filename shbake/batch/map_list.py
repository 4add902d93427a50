"""Maps given as arguments and/or a list file, and the output each writes: the input of
every command that bakes many maps in one call (``probe-fit``, ``project-env``,
``split-sum``; :mod:`shbake.batch.project_many`)."""

import os
from pathlib import Path

from shbake.errors import InputError, ParameterError, ShbakeError
from shbake.format.atomic import check_output_dir, check_output_path, makedirs, refuse_same_file
from shbake.resources import path_arguments, read_bounded

MAP_LIST_MAX_BYTES = 16 << 20
"""Largest map list read (bytes)."""


@path_arguments("path")
def read_map_list(path: str) -> list[tuple[str, str | None]]:
    """Lines ``MAP [OUTPUT]``; blank lines and ``#`` comments skipped; relative paths
    are relative to the list's folder."""
    base = Path(path).parent
    try:
        raw = read_bounded(path, MAP_LIST_MAX_BYTES, "map list (--list)")
        lines = raw.decode("utf-8").splitlines()
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: the map list is not UTF-8 text (byte {e.start})") from None
    except ShbakeError:  # refused before opening: already one line naming the path
        raise
    except OSError as e:
        raise InputError(f"{path}: cannot read the map list ({e.strerror})") from None
    out = []
    for n, line in enumerate(lines, 1):
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        if len(parts) > 2:
            raise InputError(f"{path}:{n}: expected 'MAP [OUTPUT]', got {line.strip()!r}")
        out.append((str(base / parts[0]), str(base / parts[1]) if len(parts) == 2 else None))
    return out


@path_arguments("maps", "map_list")
def map_entries(maps, map_list) -> list[tuple[str, str | None]]:
    """``(map, output or None)``: the ``maps`` given, then the list file's lines; refused
    when there is none."""
    entries = [(m, None) for m in maps] + (read_map_list(map_list) if map_list else [])
    if not entries:
        raise ParameterError("give maps as arguments or a --list file")
    return entries


@path_arguments("maps", "map_list", "out_dir")
def map_outputs(maps, map_list, out_dir: str) -> list[tuple[str, str]]:
    """``(map, output)`` pairs, absolute: each map's output ``OUT_DIR/STEM.h5`` unless the
    list names one; refused before any work: no map, two maps writing one file, an output
    that is a map, an output path that cannot be written."""
    pairs, seen = [], set()
    for src, out in map_entries(maps, map_list):
        if out is None:
            check_output_dir(out_dir, "--out-dir")
            makedirs(out_dir)  # the run's own: removed again if it fails
            out = os.path.join(out_dir, Path(src).stem + ".h5")
        out = os.path.abspath(out)
        if out in seen:
            raise ParameterError(f"two maps would write {out}; name outputs in a --list file")
        seen.add(out)
        check_output_path(out)
        pairs.append((os.path.abspath(src), out))
    refuse_same_file([o for _, o in pairs], [s for s, _ in pairs])
    return pairs


__all__ = ["MAP_LIST_MAX_BYTES", "map_entries", "map_outputs", "read_map_list"]
