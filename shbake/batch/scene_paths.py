"""Paths in a scene's state files — ``scene.lock.json``, the settings stamps and the
``plan --emit-make`` fragment — written so that the scene folder can move (issue 32).

A path is held relative to a base folder (the scene file's folder for the lock and the
stamps, the fragment's folder — where make runs — for the fragment), absolute only where
the scene file wrote it so (:attr:`shbake.batch.scene.Scene.written_absolute`: a map,
a MERL file or ``out_dir``, and what lies below it). A scene folder copied with its
outputs to another checkout or machine therefore finds its lock, stamps and fragment up
to date: nothing is baked again.
"""

import os


def stored(path: str, base: str, written_absolute=frozenset()) -> str:
    """Absolute ``path`` as a state file holds it: relative to ``base``, or as it is where
    it is, or lies below, one of ``written_absolute``."""
    if any(path == p or path.startswith(os.path.join(p, "")) for p in written_absolute):
        return path
    return os.path.relpath(path, base)


def resolved(path: str, base: str) -> str:
    """A path read from a state file, absolute: relative ones are relative to ``base``."""
    return os.path.normpath(os.path.join(base, path))


def scene_folder(scene) -> str:
    """The base of the lock's and the stamps' paths: the scene file's folder (absolute)."""
    return os.path.dirname(os.path.abspath(scene.path))


def stored_asset(asset: dict, scene, base: str | None = None) -> dict:
    """A planned ``asset`` with its ``output`` and ``inputs`` as state files hold them
    (:func:`stored`, relative to ``base``, the scene's folder by default)."""
    base = scene_folder(scene) if base is None else base
    keep = scene.written_absolute
    return dict(asset, output=stored(asset["output"], base, keep),
                inputs=[stored(p, base, keep) for p in asset["inputs"]])  # fmt: skip
