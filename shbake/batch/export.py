"""``shbake export`` as one unit of work: read assets, bake what a target needs, write its files.

The format layer (:mod:`shbake.format.exports`) serialises; this module bakes
the GGX prefiltered cube chain (:mod:`shbake.bakers.cube_prefilter`) for the
targets that carry cube maps (their ``CUBES`` defaults, overridable) and the
DFG table (:mod:`shbake.bakers.dfg`) for ``ktx2``. Maps given instead of assets:
:mod:`shbake.batch.export_map`.
"""

import os
import time

from shbake.bakers.cube_chain import check_chain, extend_chain, prefilter_chain
from shbake.bakers.cube_prefilter import mirror_cube, mirror_supersample
from shbake.bakers.dfg import dfg_table
from shbake.errors import ParameterError
from shbake.evaluation.cube_chain import chain_errors, chain_warnings
from shbake.format.atomic import check_output_dir, check_output_path, makedirs, transaction
from shbake.format.exports import check_ending, target_module
from shbake.format.exports.source import ExportSource, load_source, require_sh
from shbake.resources import path_arguments

TARGET_OPTIONS = {
    "env_path": "--env",
    "size": "--size",
    "floor": "--floor",
    "samples": "--samples",
    "mapping": "--lod-mapping",
    "sun_radius_deg": "--sun-radius",
    "babylon_scene": "--babylon-scene",
}
"""Settings that only some targets read, and the option that sets each."""
FIXED_LOD_MAPPING = ("filament", "threejs-pmrem")
"""Targets whose engine shader fixes the roughness of each mip level (their ``CUBES`` mapping)."""


def options_of_target(target: str) -> frozenset:
    """The :data:`TARGET_OPTIONS` that ``target`` reads: the cube-chain settings where it
    writes cube maps (``CUBES``; not ``mapping`` for :data:`FIXED_LOD_MAPPING`),
    ``babylon_scene`` for ``gltf``/``babylon``."""
    reads = set()
    if target_module(target).CUBES is not None:
        reads |= {"env_path", "size", "floor", "samples", "sun_radius_deg"}
        if target not in FIXED_LOD_MAPPING:
            reads.add("mapping")
    if target in ("gltf", "babylon"):
        reads.add("babylon_scene")
    if target == "webgl":
        reads.add("env_path")  # the env_sh asset lighting a brdf_table
    return frozenset(reads)


def check_target_options(target: str, explicit=()) -> None:
    """Refuse (:class:`~shbake.errors.ParameterError`) a setting of :data:`TARGET_OPTIONS`
    named in ``explicit`` that ``target`` does not read."""
    reads = options_of_target(target)
    stray = [o for k, o in TARGET_OPTIONS.items() if k in explicit and k not in reads]
    if stray:
        raise ParameterError(f"{', '.join(stray)}: not read for --to {target}")


def cube_settings(target: str, size=None, floor=None, samples=None, mapping=None) -> dict | None:
    """The cube-chain settings of ``target`` (its ``CUBES`` with the given ones replacing them;
    :data:`FIXED_LOD_MAPPING` targets always take their engine's mapping), checked
    (:func:`check_chain`: a :class:`~shbake.errors.ParameterError` before any input is read);
    ``None`` for a target without cube maps."""
    cubes = target_module(target).CUBES
    if cubes is None:
        return None
    given = {"size": size, "floor": floor, "samples": samples}
    if target not in FIXED_LOD_MAPPING:
        given["mapping"] = mapping
    cfg = dict(cubes) | {k: v for k, v in given.items() if v is not None}
    check_chain(cfg["size"], cfg["floor"], cfg["samples"])
    return cfg


@path_arguments("assets", "env_path")
def load_sources(assets: list[str], target: str, frame: str = "y-up", rotate_deg: float = 0.0,
                 env_path: str | None = None) -> list[ExportSource]:  # fmt: skip
    """Read every asset of a batch for ``target`` and check it before any export work
    (:func:`~shbake.format.exports.source.load_source`: its kind, its irradiance SH, lights
    engines cannot shade — sphere lights; :func:`~shbake.format.exports.source.require_sh`:
    SH, for every target but ``ktx2``), so that an asset the target refuses stops the batch
    before an earlier one's cube chain is baked or its files written. Returns the source of
    each, in the target frame."""
    sources = [load_source(path, frame=frame, rotate_deg=rotate_deg, env_path=env_path)
               for path in assets]  # fmt: skip
    if target != "ktx2":  # ktx2 carries cube maps, no SH
        for src in sources:
            require_sh(src, target)
    return sources


@path_arguments("assets", "out", "env_path")
def export_assets(
    assets: list[str],
    target: str,
    out: str,
    frame: str = "y-up",
    rotate_deg: float = 0.0,
    env_path: str | None = None,
    sun_radius_deg: float = 10.0,
    size: int | None = None,
    floor: int | None = None,
    samples: int | None = None,
    mapping: str | None = None,
    many: bool | None = None,
    explicit=(),
    glossy_report: list | None = None,
    **options,
) -> list[str]:
    """Export each asset file in ``assets`` to ``target``; returns the files written.

    Parameters
    ----------
    out : str
        The output file for one asset, or a folder (created) for several.
    many : bool, optional
        Treat ``out`` as a folder even for one asset (default: when several).
    frame, rotate_deg
        Target frame (:func:`shbake.format.exports.source.frame_matrix`).
    env_path : str, optional
        Source map of the cube chains (default: the path recorded in the asset).
    sun_radius_deg : float
        Radius the asset's sun was extracted with (to rebuild its residual map).
    size, floor, samples, mapping
        Cube chain settings; ``None`` takes the target's ``CUBES`` defaults
        (:data:`FIXED_LOD_MAPPING` targets always use their engine's).
    explicit
        Names of the settings the caller set on purpose (the command line's); one
        of :data:`TARGET_OPTIONS` that ``target`` does not read raises
        :class:`~shbake.errors.ParameterError` rather than being ignored.
    glossy_report : list, optional
        Where given, each asset's cube chain is measured as its engine reads it
        (:func:`shbake.evaluation.cube_chain.chain_errors`) and ``{"input", "size",
        "floor", "samples", "mapping", "levels", "bake_s", "roughness": [...], "warnings"}``
        appended.
    options
        Passed to the target's ``write`` (e.g. ``babylon_scene``).
    """
    mod = target_module(target)
    check_target_options(target, explicit)
    if not assets:
        raise ParameterError("no asset to export")
    one_file = not (many if many is not None else len(assets) > 1)
    if target == "webgl":
        return _export_webgl(assets, out, one_file, frame, rotate_deg, env_path)
    if one_file:  # refused before the cube chains are baked
        check_output_path(out)
        check_ending(target, out)
    else:
        check_output_dir(out, "--out-dir")
    written = []
    sources = load_sources(assets, target, frame, rotate_deg, env_path)
    for path, src in zip(assets, sources, strict=True):
        if one_file:
            dest = out
        else:
            makedirs(out)
            stem = os.path.splitext(os.path.basename(path))[0]
            dest = os.path.join(out, stem + mod.EXTENSION)
        extra = dict(options)
        cfg = cube_settings(target, size, floor, samples, mapping)
        if cfg is not None:
            env = src.environment(sun_radius_deg)
            start = time.perf_counter()
            levels, rough = prefilter_chain(
                env,
                size=cfg["size"],
                floor=cfg["floor"],
                mapping=cfg["mapping"],
                samples=cfg["samples"],
                rotation=src.cube_rotation,
                min_roughness=cfg.get("min_roughness", 0.0),
            )
            if glossy_report is not None:
                glossy_report.append(_chain_report(path, cfg, env, levels, src.cube_rotation,
                                                   time.perf_counter() - start))  # fmt: skip
            if target == "babylon" and dest.endswith(".env"):  # a .env holds every level
                levels, rough = extend_chain(levels, rough)
            extra.update(levels=levels, roughness=rough, mapping=cfg["mapping"])
            if target == "filament":  # the map as a cube, beside a chain fitted to its blend
                extra["skybox"] = mirror_cube(env, cfg["size"],
                                              mirror_supersample(env, cfg["size"]),
                                              src.cube_rotation)  # fmt: skip
            if target == "ktx2":
                extra["dfg_table"] = dfg_table()
        written += mod.write(src, dest, **extra)
    return written


def _chain_report(path, cfg, env, levels, rotation, bake_s) -> dict:
    errors = chain_errors(env, levels, cfg["mapping"], rotation)
    return {"input": path, "levels": len(levels), "bake_s": bake_s,
            **{k: cfg[k] for k in ("size", "floor", "samples", "mapping")},
            "roughness": errors, "warnings": chain_warnings(errors)}  # fmt: skip


@path_arguments("asset_path", "env_path")
def export_error(asset_path: str, env_path: str | None = None, n_dirs: int = 2048,
                 scene_check: bool = False, whole: bool = False) -> tuple[dict, dict]:  # fmt: skip
    """The error of what an engine evaluates from any SH export of the ``env_sh`` asset (its
    9 irradiance coefficients and lights; ``whole``: all its irradiance coefficients, what
    ``--to webgl`` draws) against brute force of its source map (the recorded one, or
    ``env_path``; hash-checked), in the asset's pose, at ``n_dirs`` Fibonacci directions
    (:func:`shbake.evaluation.env_sh.export_irradiance_errors`), and how it was measured
    (``{"irradiance": method}``). ``scene_check``: the scene bake's reference, as cheap as
    the bake (:func:`shbake.evaluation.env_sh.check_reference`, its own direction count),
    instead of the texel-by-texel sum."""
    from shbake.envmap.turn import recorded_turn
    from shbake.evaluation.env_sh import (
        EXPORT_COEFFS,
        brute_force_reference,
        check_reference,
        export_irradiance_errors,
    )
    from shbake.format.asset import read_asset
    from shbake.format.provenance import reload_source

    asset = read_asset(asset_path, kinds=("env_sh",))
    env = reload_source(asset, asset_path, env_path)
    turn = recorded_turn(asset)
    if scene_check:
        ref = check_reference(env, ["irradiance"])
        methods = ref["methods"]
    else:
        ref = brute_force_reference(env, n_dirs=n_dirs, names=("irradiance",))
        methods = {"irradiance": "brute-force"}
    coeffs = None if whole else EXPORT_COEFFS
    return export_irradiance_errors(asset, env, ref, rotation=turn, coeffs=coeffs), methods


@path_arguments("assets", "env_path")
def load_webgl(assets: list[str], env_path: str | None = None) -> list[tuple[dict, dict]]:
    """Read every asset of a ``--to webgl`` batch and build its export
    (:func:`shbake.format.exports.webgl.build_export`, which runs every check of its kind: at
    most 8 lights, of either shape; a table's lmax; the probe's levels and sets), so that an
    asset the target refuses stops the batch before any file is written. ``env_path``: the
    ``env_sh`` asset that lights the batch's ``brdf_table`` assets (the kautz pass), given
    exactly when the batch holds one (else :class:`~shbake.errors.ParameterError`) and read
    for them alone. Returns ``(manifest, textures)`` of each asset, in order."""
    from shbake.format.asset import read_asset
    from shbake.format.brdf_table import table_at
    from shbake.format.exports.webgl import TEXTURES_OF_KIND, build_export
    from shbake.shading.brdf_table import lighting_with_sun
    from shbake.shading.env_sh import lights_of

    read = [(path, read_asset(path, kinds=tuple(TEXTURES_OF_KIND))) for path in assets]
    tables = any(asset.kind == "brdf_table" for _, asset in read)
    if tables != (env_path is not None):
        raise ParameterError("--to webgl: a brdf_table needs --env ENV_SH.h5 (its lighting); "
                             "--env is read for brdf_table assets only")  # fmt: skip
    env = read_asset(env_path, kinds=("env_sh",)) if tables else None
    exports = []
    for path, asset in read:
        if asset.kind == "env_sh":
            context = lights_of(asset)
        elif asset.kind == "brdf_table":
            table = table_at(asset)
            context = (table, lighting_with_sun(env, table.lmax))
        else:
            context = None
        exports.append(build_export(asset, os.path.basename(path), context, path))
    return exports


def _export_webgl(assets, out, one_file, frame, rotate_deg, env_path) -> list[str]:
    """``--to webgl``: one folder per asset (``out`` itself for one), shbake's world frame,
    in one transaction once every asset is checked (:func:`load_webgl`)."""
    from shbake.format.exports.webgl import write_export

    if frame != "y-up" or rotate_deg != 0.0:
        raise ParameterError("--to webgl writes shbake's world frame: no --frame z-up or --rotate")
    check_output_dir(out, "-o/--output" if one_file else "--out-dir")
    exports = load_webgl(assets, env_path)
    written = []
    with transaction():
        for path, (manifest, textures) in zip(assets, exports, strict=True):
            stem = os.path.splitext(os.path.basename(path))[0]
            dest = out if one_file else os.path.join(out, stem)
            written += write_export(manifest, textures, dest)
    return written


__all__ = [
    "FIXED_LOD_MAPPING",
    "TARGET_OPTIONS",
    "check_target_options",
    "cube_settings",
    "export_assets",
    "export_error",
    "load_sources",
    "load_webgl",
    "options_of_target",
]
