"""Engine-ready exports of shbake assets, one module per target (``docs/EXPORTS.md``).

``TARGETS`` maps a target name to its module; every module has
``write(source, out, **options) -> list[str]`` taking an
:class:`~shbake.format.exports.source.ExportSource` (already in the target's
frame) and, for targets with cube maps (``CUBES`` not None), the prefiltered
chain; it returns the files written. ``OUTPUT_ENDINGS`` (a tuple, or ``None`` for any name)
are the endings its ``out`` may have (:func:`check_ending`). The format layer only serialises:
:func:`shbake.batch.export.export_assets` (the one library entry point of
``shbake export`` and ``project-env --export``) bakes the cube chains.
"""

import importlib

from shbake.errors import ParameterError

TARGETS = {
    "gltf": "shbake.format.exports.gltf",
    "babylon": "shbake.format.exports.babylon",
    "threejs": "shbake.format.exports.threejs",
    "threejs-pmrem": "shbake.format.exports.three_pmrem",
    "ktx2": "shbake.format.exports.ktx2",
    "filament": "shbake.format.exports.filament",
    "unity": "shbake.format.exports.unity",
    "webgl": "shbake.format.exports.webgl",
}
"""Target name → module (``babylon``: the glTF export, Babylon implements the extension, or
Babylon's ``.env``)."""


def target_module(name: str):
    """The module that writes target ``name``."""
    if name not in TARGETS:
        raise ParameterError(f"unknown export target {name!r}; choose one of {', '.join(TARGETS)}")
    return importlib.import_module(TARGETS[name])


def check_ending(name: str, out: str) -> None:
    """Refuse an output file ``out`` that target ``name`` does not write (its module's
    ``OUTPUT_ENDINGS``): a :class:`~shbake.errors.ParameterError` before anything is baked."""
    endings = target_module(name).OUTPUT_ENDINGS
    if endings is not None and not str(out).endswith(endings):
        raise ParameterError(f"{out}: --to {name} writes a file ending {' or '.join(endings)}")


__all__ = ["TARGETS", "check_ending", "target_module"]
