"""Engine-ready exports of shbake assets, one module per target (``docs/EXPORTS.md``).

``TARGETS`` maps a target name to its module; every module has
``write(source, out, **options) -> list[str]`` taking an
:class:`~shbake.format.exports.source.ExportSource` (already in the target's
frame) and returning the files written. :func:`export_assets` is the one
library entry point of ``shbake export`` and of ``project-env --export``.
"""

import importlib

from shbake.errors import ParameterError

TARGETS = {
    "gltf": "shbake.format.exports.gltf",
    "babylon": "shbake.format.exports.gltf",
    "threejs": "shbake.format.exports.threejs",
    "ktx2": "shbake.format.exports.ktx2",
    "filament": "shbake.format.exports.filament",
    "unity": "shbake.format.exports.unity",
}
"""Target name → module (``babylon`` = the glTF export: Babylon implements the extension)."""


def target_module(name: str):
    """The module that writes target ``name``."""
    if name not in TARGETS:
        raise ParameterError(f"unknown export target {name!r}; choose one of {', '.join(TARGETS)}")
    return importlib.import_module(TARGETS[name])


def export_assets(
    assets: list[str],
    target: str,
    out: str,
    frame: str = "y-up",
    rotate_deg: float = 0.0,
    env_path: str | None = None,
    **options,
) -> list[str]:
    """Export each asset file in ``assets`` to ``target``; returns the files written.

    ``out`` is the output file for one asset, or a directory (created) for several.
    ``frame``/``rotate_deg``: :func:`shbake.format.exports.source.frame_matrix`.
    """
    import os

    from shbake.format.exports.source import load_source

    mod = target_module(target)
    if not assets:
        raise ParameterError("no asset to export")
    written = []
    for path in assets:
        src = load_source(path, frame=frame, rotate_deg=rotate_deg, env_path=env_path)
        if len(assets) == 1:
            dest = out
        else:
            os.makedirs(out, exist_ok=True)
            stem = os.path.splitext(os.path.basename(path))[0]
            dest = os.path.join(out, stem + mod.EXTENSION)
        written += mod.write(src, dest, **options)
    return written


__all__ = ["TARGETS", "export_assets", "target_module"]
