"""``shbake export MAP``: one step from an environment map to an engine (issue 32).

:func:`export_inputs` exports each input as :func:`shbake.batch.export.export_assets`
does; an input that is an environment map, not an asset, is first baked into an
``env_sh`` asset with :data:`MAP_DEFAULTS` (as ``project-env`` would, measured against
brute force with the headline error of what the engines evaluate), which is staged in
the run's transaction, read back by the export and dropped unless ``keep_asset`` names
where to keep it.
"""

import os

import numpy as np

from shbake.batch.export import (
    check_target_options,
    export_assets,
    export_error,
    load_sources,
    load_webgl,
)
from shbake.batch.project_env import check_settings, headline_error, project_environment
from shbake.errors import ParameterError
from shbake.format.asset import is_asset_file
from shbake.format.atomic import check_output_dir, makedirs, staged, transaction
from shbake.format.exports import target_module
from shbake.progress import NO_PROGRESS
from shbake.resources import path_arguments

MAP_OPTIONS = {
    "lmax": "--lmax",
    "window": "--window",
    "extract_sun": "--extract-sun/--no-extract-sun",
    "lights": "--lights",
    "keep_asset": "--keep-asset",
    "layout": "--layout",
    "negative": "--negative",
    "fix_nonfinite": "--fix-nonfinite",
    "colorspace": "--colorspace",
}
"""Settings read only for an environment-map input (its bake), and the option of each."""
MAP_DEFAULTS = {"lmax": 2, "window": "none", "extract_sun": True, "lights": None}
"""How a map input is baked unless told: lmax 2 (every SH target reads the first 9
coefficients), no window, the dominant compact light taken out as a directional light
where the map has one (``project-env``'s advice; nothing is taken from a map without one)."""


@path_arguments("inputs", "out", "keep_asset")
def export_inputs(
    inputs: list[str],
    target: str,
    out: str,
    many: bool | None = None,
    bake: dict | None = None,
    keep_asset: str | None = None,
    report: bool = False,
    explicit=(),
    progress=NO_PROGRESS,
    **options,
) -> dict:
    """Export each of ``inputs`` to ``target`` (:func:`export_assets`); an input that is not
    an HDF5 asset is an environment map, baked first into an ``env_sh`` asset with
    :data:`MAP_DEFAULTS` updated by ``bake`` (``lmax``, ``window``, ``extract_sun``,
    ``lights`` — which, unless ``extract_sun`` is explicit, replace the sun —, the input
    policies) and measured against brute force (the ``project-env --report`` error).

    The baked asset is an output of the run's transaction, read back by the export and
    then discarded; ``keep_asset`` (one map input) keeps it there. ``report``: an asset
    input's export is measured too (:func:`measure_asset`; a map's always is; a target with
    cube maps: each input's chain as its engine reads it,
    :func:`shbake.batch.export.export_assets` ``glossy_report``). Returns ``{"written": files,
    "bakes": [the project-env summary of each map], "measured": [the :func:`measure_asset`
    entry of each asset input], "glossy": [the chain report of each input]}``. Settings of
    :data:`MAP_OPTIONS` named in ``explicit`` without a map input, or of
    :data:`TARGET_OPTIONS` the target does not read, raise
    :class:`~shbake.errors.ParameterError` before anything is baked; an asset input the
    target cannot take (:func:`~shbake.batch.export.load_sources`: sphere lights, no SH;
    :func:`~shbake.batch.export.load_webgl`: more than 8 lights, …) is refused then too,
    whatever its place among the inputs. ``webgl``: the asset inputs are exported together, one
    batch whose ``brdf_table`` assets the ``--env`` asset lights (it needs one, and ``--env``
    needs a table), before the maps; a map's ``env_sh`` asset does not read ``--env``.
    """
    check_target_options(target, explicit)
    one_file = not (many if many is not None else len(inputs) > 1)
    maps = [p for p in inputs if not is_asset_file(p)]
    given = [o for k, o in MAP_OPTIONS.items() if k in explicit]
    if given and not maps:
        raise ParameterError(f"{', '.join(given)}: read for an environment-map input only")
    if keep_asset is not None and len(maps) != 1:
        raise ParameterError("--keep-asset keeps the asset of one map input")
    settings = MAP_DEFAULTS | {k: v for k, v in (bake or {}).items() if v is not None}
    if settings["lights"] is not None and "extract_sun" not in explicit:
        settings["extract_sun"] = False  # fitted lights replace the extracted sun
    lmax, lights = settings["lmax"], settings["lights"]
    check_settings(lmax, min(lmax, 2), True, ("threejs",), lights, 0.01,
                   settings["extract_sun"], settings["window"])  # fmt: skip
    if not one_file:
        check_output_dir(out, "--out-dir")
    assets = [p for p in inputs if p not in maps]
    webgl = target == "webgl"  # --env lights the brdf_table assets of the whole batch
    if webgl:  # every asset input checked before any map is baked or exported
        load_webgl(assets, options.get("env_path"))
    else:
        load_sources(assets, target)
    written, bakes, measured = [], [], []
    glossy = [] if report and target_module(target).CUBES is not None else None
    with transaction() as t:
        if webgl and assets:  # one batch, the one the --env rule reads
            written += export_assets(assets, target, out, many=not one_file, explicit=explicit,
                                     **options)  # fmt: skip
        for path in inputs:
            if path not in maps:
                if not webgl:
                    written += export_assets([path], target, out, many=not one_file,
                                             explicit=explicit, glossy_report=glossy,
                                             **options)  # fmt: skip
                if report and target != "ktx2":  # ktx2 carries cube maps, no SH
                    measured.append(measure_asset(path, target, options.get("env_path")))
                continue
            folder = out if not one_file else os.path.dirname(os.path.abspath(out))
            stem = os.path.splitext(os.path.basename(path))[0]
            asset = keep_asset or os.path.join(folder, stem + ".h5")
            if not one_file:
                makedirs(out)
            summary = project_environment(
                path, asset, lmax=settings["lmax"], window=settings["window"],
                irradiance_lmax=min(settings["lmax"], 2), tangent_irradiance=False,
                extract_sun=settings["extract_sun"], lights=settings["lights"],
                sun_radius=options.get("sun_radius_deg", 10.0), report=True,
                measure_export=target != "ktx2",  # ktx2 carries cube maps, no SH
                **{k: settings.get(k) for k in ("layout", "negative", "fix_nonfinite",
                                                "colorspace")},
                progress=progress,
            )  # fmt: skip
            own = options
            if target_module(target).CUBES is not None:  # the cube chain's map: this one
                own = options | {"env_path": options.get("env_path") or path}
            if webgl:  # an env_sh asset: --env lights the batch's brdf_table assets alone
                own = options | {"env_path": None}
            files = export_assets([asset], target, out, many=not one_file, explicit=explicit,
                                  glossy_report=glossy, **own)  # fmt: skip
            if glossy:
                glossy[-1]["input"] = path
            if keep_asset is None:
                t.discard(staged(asset))
                summary["outputs"] = files
            else:
                summary["outputs"] = [asset, *files]
            written += summary["outputs"]
            bakes.append(summary)
    return {"written": written, "bakes": bakes, "measured": measured, "glossy": glossy or []}


WEBGL_NOT_MEASURED = {
    "splitsum_probe": "shbake has no error model for split-sum",
}
"""Why ``export --to webgl --report`` measures no asset of these kinds."""
WEBGL_TABLE = ("BRDF table the kautz pass reads (f* rebuilt from its look-up vs f* itself, "
               "the brdf-table headline)")  # fmt: skip
"""What ``export --to webgl --report`` measures of a ``brdf_table`` asset."""
WEBGL_SHRM = ("shrm pass on a 24² sphere seen from +Z, against brute force of its map "
              "(shrm --report's measured error)")  # fmt: skip
"""What ``export --to webgl --report`` measures of an ``shrm`` asset."""
MEASURED_BRDF = "a measured BRDF, whose MERL file export does not read"
"""Why a Kautz table or SHRM of a MERL BRDF is not measured: an asset makes shbake read no
file but its hash-checked source map (docs/SECURITY.md §3)."""


def _probe_error(asset, path: str) -> dict:
    """The probe-fit headline (:func:`~shbake.evaluation.probes.glossy_error`) of an SH-exp
    probe, or of every probe of a set (the worst as ``value``, each in ``by_probe``),
    against its recorded map seen in its pose."""
    from shbake.envmap.environment import decoded_once
    from shbake.envmap.turn import recorded_turn
    from shbake.evaluation.probes import glossy_error
    from shbake.format.provenance import reload_source
    from shbake.format.shexp import probe_from_set

    if asset.kind == "shexp_probe":
        probes = [asset]
    else:
        probes = [probe_from_set(asset, i) for i in range(int(asset.attrs["probe_count"]))]
    with decoded_once():  # probes of one map (its poses) decode it once
        errors = [glossy_error(p, reload_source(p, path), recorded_turn(p)) for p in probes]
    worst = max(errors, key=lambda e: e["value"])
    if len(errors) > 1:
        worst = worst | {"quantity": f"{worst['quantity']}, the worst of {len(errors)} probes",
                         "by_probe": [e["value"] for e in errors]}  # fmt: skip
    return worst | {"measure": "relative RMS of luminance vs brute force"}


def _shrm_error(asset, path: str) -> dict:
    """``{"error"}`` of an SHRM (:data:`WEBGL_SHRM`, the relative RMS of
    :class:`~shbake.evaluation.shrm.ShrmCheck`), or ``{"note"}`` where none is measured."""
    from shbake.brdf.reflection import make_reflection_brdf
    from shbake.envmap.turn import recorded_turn
    from shbake.evaluation.shrm import ShrmCheck
    from shbake.format.provenance import reload_source
    from shbake.shading.shader import shader

    sh = shader(asset)
    model, params, _ = sh.brdf()
    if model == "merl":
        return {"note": MEASURED_BRDF}
    rb = make_reflection_brdf(model, params)
    if rb.kind == "tangent":
        return {"note": "the tangent kind shades no surface (shrm --report measures none)"}
    check = ShrmCheck(reload_source(asset, path), rb, rotation=recorded_turn(asset))
    return {"error": {"quantity": WEBGL_SHRM, "value": float(np.sqrt(check.rel_energy(asset))),
                      "measure": "relative RMS vs brute force"}}  # fmt: skip


@path_arguments("path", "env_path")
def measure_asset(path: str, target: str, env_path: str | None = None) -> dict:
    """The ``--report`` entry ``{"input", "error"}`` of the asset input ``path`` exported to
    ``target`` (not ``ktx2``: cube maps, no SH): the headline
    (:func:`~shbake.batch.project_env.headline_error`) of what the engine evaluates
    (:func:`~shbake.batch.export.export_error`: 9 irradiance coefficients and the lights,
    against brute force of ``env_path`` or the recorded source map).

    ``webgl`` (``"kind"`` added) measures by the asset's kind, and ``env_path`` there is the
    ``env_sh`` asset lighting the tables, never a source map: an ``env_sh`` asset's whole
    irradiance SH and lights, what the webgl passes draw, against its recorded source map; a
    ``brdf_table`` at the point the export draws (:data:`WEBGL_TABLE`,
    :func:`~shbake.batch.brdf_table.written_table_error`: ``{"quantity", "value",
    "truncation", "coefficients", "views", "lmax"}``); an SH-exp probe (or set) by
    probe-fit's headline and an SHRM by :data:`WEBGL_SHRM`, each against its recorded map
    in its pose (``{"quantity", "value", "measure"}``; a set adds ``by_probe``); where
    nothing is measured (a measured MERL BRDF, an SHRM of the tangent kind,
    :data:`WEBGL_NOT_MEASURED`) ``error`` is ``None`` and ``note`` says why."""
    if target != "webgl":
        errors, _ = export_error(path, env_path)
        return {"input": path, "error": headline_error({"export": errors})}
    from shbake.format.asset import read_asset
    from shbake.format.exports.webgl import TEXTURES_OF_KIND

    asset = read_asset(path, kinds=tuple(TEXTURES_OF_KIND))
    entry = {"input": path, "kind": asset.kind, "error": None}
    if asset.kind == "env_sh":
        errors, _ = export_error(path, whole=True)
        return entry | {"error": headline_error({"irradiance": errors})}
    if asset.kind in ("shexp_probe", "shexp_probe_set"):
        return entry | {"error": _probe_error(asset, path)}
    if asset.kind == "shrm":
        return entry | _shrm_error(asset, path)
    if asset.kind != "brdf_table":
        return entry | {"note": WEBGL_NOT_MEASURED[asset.kind]}
    from shbake.batch.brdf_table import written_table_error

    errors = written_table_error(asset)
    if errors is None:
        return entry | {"note": MEASURED_BRDF}
    return entry | {"error": {"quantity": WEBGL_TABLE, "value": errors.pop("error"), **errors}}


__all__ = ["MAP_DEFAULTS", "MAP_OPTIONS", "WEBGL_NOT_MEASURED", "export_inputs", "measure_asset"]
