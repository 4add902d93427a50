"""``project-env`` as one unit of work: read a map, bake ``env_sh``, write it and its companions.

:func:`project_environment` is what the command runs: it validates every
setting before reading the map, bakes the asset (:mod:`shbake.bakers.env_sh`),
optionally measures it (``report``: truncation per band and the error against
brute force, :mod:`shbake.evaluation.env_sh`), writes the asset, the lat-long
irradiance maps and the engine exports, and returns a summary with the
quality warnings a user should act on.
"""

import os

import numpy as np

from shbake.bakers.env_lights import MAX_LIGHTS
from shbake.bakers.env_sh import bake_env_sh, check_lights, truncation_report
from shbake.conventions import check_lmax, to_float32
from shbake.envmap import load_environment
from shbake.envmap import sun as sun_light
from shbake.envmap.layouts import latlong_directions
from shbake.errors import OutputError, ParameterError
from shbake.evaluation.metrics import HEADLINE_WARNING
from shbake.format.asset import write_asset
from shbake.format.atomic import check_output_dir, check_output_path, makedirs
from shbake.format.env_sh import asset_lights
from shbake.format.images import HALF_MAX, tonemap_to_srgb8, write_exr, write_png
from shbake.progress import NO_PROGRESS
from shbake.resources import check_memory, path_arguments
from shbake.sh.point_sets import fibonacci_sphere
from shbake.shading.shader import shader

EXPORTS = ("gltf", "babylon", "threejs")
"""The engines ``--export`` writes beside the asset, as ``shbake export --to TARGET`` would."""
TRUNCATION_WARNING = HEADLINE_WARNING["env_sh"]
"""Relative RMS error of luminance against brute force (the headline's measure) above which
``--report`` warns about an error, with the options that lower it (:func:`lowering`)."""
MINIMUM_DIRECTIONS = 4096
"""Directions at which the baked irradiance is checked for negative values."""
RINGING_FLOOR = 1e-9
"""Irradiance below zero by less than this fraction of its mean is round-off (a single
bright texel left −6e-18 against a mean of 30), not ringing: no warning."""


MAP_TEXEL_BYTES = 96
"""Working memory per texel of the ``--exr-dir`` maps: directions, the two float64 maps,
their half-float and tone-mapped copies."""
REPORT_TEXEL_BYTES = 192
"""Working memory per texel of the source map for ``--report``: the brute-force sweep's
samples and weighted copies, and the float64 squares of the truncation report (tracemalloc
peak 149 B at 512x1024, ``tests/system/faults/test_memory.py::TestProjectEnvMemory``)."""


def project_memory(texels: int, map_size: int | None, report: bool) -> int:
    """Estimated bytes beyond the loaded map of :func:`project_environment`: the
    ``--exr-dir`` maps of ``map_size`` rows and, with ``report``, the sweep over ``texels``."""
    maps = 0 if map_size is None else 2 * map_size * map_size * MAP_TEXEL_BYTES
    return maps + (REPORT_TEXEL_BYTES * texels if report else 0)


def quality_warnings(asset, summary: dict) -> list[str]:
    """Plain-language warnings about a baked ``env_sh`` asset, each with the fix to try.

    Negative Lambert irradiance anywhere on a Fibonacci sphere means ringing
    (Gibbs) from a compact bright source; a ``--report`` error above
    :data:`TRUNCATION_WARNING` means the light the consumer reads (its bands, the
    sun or lights) is too little for the map.
    """
    out = []
    fixes = []
    lights = summary.get("lights")
    if summary.get("window") != "dering" and not lights:
        fixes.append("--window dering")
    if not summary.get("sun", {}).get("extracted") and not lights:
        fixes.append("--extract-sun")
    if lights and lights.get("met") is False:
        out.append(
            f"--lights auto: no fit with at most {max(f['count'] for f in lights['tried'])} "
            "lights meets "
            f"--tol {lights['tolerance']:g}; kept {lights['count']} (mean error "
            f"{lights['mean_error']:.2%}, max {lights['max_error']:.2%})"
        )
    if "/irradiance/sh" in asset:
        e = shader(asset, "irradiance").irradiance(fibonacci_sphere(MINIMUM_DIRECTIONS))
        lowest = float(e.min())
        if lowest < -RINGING_FLOOR * abs(float(e.mean())):
            hint = f"; try {' or '.join(fixes)}" if fixes else ""
            out.append(
                f"irradiance rings below zero (min {lowest:.4g} vs mean "
                f"{float(e.mean()):.4g}, the map's radiance unit × sr){hint}"
            )
    errors = summary.get("report", {}).get("error_vs_brute_force", {})
    same = "export" in errors and summary.get("irradiance_lmax", 0) <= 2  # one error, twice
    for name, err in errors.items():
        if err["relative_rms"] > TRUNCATION_WARNING and not (same and name == "irradiance"):
            hint = " or ".join(lowering(name, summary))
            out.append(
                f"{name} differs from brute force by {err['relative_rms']:.1%} (relative RMS of "
                f"luminance; mean {err['mean']:.1%}, max {err['max']:.0%} relative); try {hint}"
            )
    return out


def lowering(name: str, summary: dict) -> list[str]:
    """The options that lower the measured error ``name`` (a key of ``error_vs_brute_force``)
    of a bake ``summary``: taking the sun out or fitting lights (the part of the light no
    band limit holds; measured on the six sample maps at lmax 8, the export's relative RMS
    error is 0.95-2.06 % with --extract-sun, 0.74-1.46 % with --lights auto --tol 0.02),
    and, where the consumer reads more than 9 coefficients (not ``export``), more bands."""
    lights, tried_sun = summary.get("lights"), "sun" in summary  # --extract-sun was given
    out = [] if lights or tried_sun else ["--extract-sun"]
    if not lights:
        out.append("--lights auto")
    elif lights["count"] < MAX_LIGHTS:
        out.append(f"--lights {lights['count'] + 1}")
    if name == "irradiance":
        more = summary["irradiance_lmax"] < summary["lmax"]
        out.append("a higher --irradiance-lmax" if more else
                   "a higher --lmax and --irradiance-lmax")  # fmt: skip
    elif name == "tangent_irradiance":
        out.append("a higher --lmax")
    return out


HEADLINE_OF = {
    "export": "irradiance an engine evaluates from the export (9 SH coefficients + lights)",
    "irradiance": "irradiance of the asset (its irradiance SH + lights)",
    "tangent_irradiance": "tangent irradiance of the asset",
}
"""What each measured error is of, in the order the headline is chosen: what a consumer
evaluates (the export when there is one), else the asset itself."""


def headline_error(errors: dict) -> dict | None:
    """The headline of the ``--report`` ``errors`` (:data:`HEADLINE_OF`'s first present):
    ``{"quantity", "value"}`` (relative RMS of luminance against brute force, the scene's
    measure) with its ``mean`` and ``max`` relative error; ``None`` when none was measured."""
    for name, what in HEADLINE_OF.items():
        if name in errors:
            e = errors[name]
            return {"quantity": what, "value": e["relative_rms"], "mean": e["mean"],
                    "max": e["max"]}  # fmt: skip
    return None


def export_folder(output: str, target: str) -> str:
    """The folder of ``--export TARGET``'s files beside the asset ``output``: ``sky.h5`` →
    ``sky-gltf/`` (``sky.gltf`` and its 24 specular PNGs), ``sky-threejs/`` (``sky.json``)."""
    return f"{os.path.splitext(output)[0]}-{target}"


def check_settings(lmax: int, irradiance_lmax: int | None = None, irradiance_sh: bool = True,
                   exports: tuple[str, ...] = (), lights: int | str | None = None,
                   light_tol: float = 0.01, extract_sun: bool = False,
                   window: str = "none", light_shape: str = "point") -> int:  # fmt: skip
    """The band limits and light settings of :func:`project_environment` checked before any
    input is read (a :class:`~shbake.errors.ParameterError` names the first bad one); returns
    the irradiance ``lmax`` (default ``min(lmax, 2)``, at most ``lmax``; an export needs 2)."""
    check_lmax(lmax)
    irradiance_lmax = min(lmax, 2) if irradiance_lmax is None else irradiance_lmax
    check_lmax(irradiance_lmax, "--irradiance-lmax", limit=lmax)
    if exports and (not irradiance_sh or irradiance_lmax < 2):
        raise ParameterError("--export needs --irradiance with irradiance lmax >= 2")
    check_lights(lights, light_tol, extract_sun, window, light_shape)
    if light_shape != "point" and exports:
        raise ParameterError(f"--export: engines shade lights as points, not --light-shape "
                             f"{light_shape} (export --to webgl draws them)")  # fmt: skip
    return irradiance_lmax


@path_arguments("env_path", "output")
def project_environment(env_path: str, output: str, **settings) -> dict:
    """Bake ``env_path`` into the ``env_sh`` asset ``output`` (and companions); the summary
    (:func:`project_environment_asset`, whose keyword ``settings`` it takes)."""
    return project_environment_asset(env_path, output, **settings)[1]


@path_arguments("env_path", "output", "exr_dir")
def project_environment_asset(
    env_path: str,
    output: str,
    lmax: int = 2,
    window: str = "none",
    irradiance_lmax: int | None = None,
    irradiance_sh: bool = True,
    tangent_irradiance: bool = True,
    extract_sun: bool = False,
    sun_radius: float = sun_light.SUN_RADIUS_DEG,
    lights: int | str | None = None,
    light_tol: float = 0.01,
    light_shape: str = "point",
    exr_dir: str | None = None,
    map_size: int = 128,
    float_exr: bool = False,
    png: bool = False,
    exports: tuple[str, ...] = (),
    report: bool = False,
    layout: str | None = None,
    negative: str | None = None,
    fix_nonfinite: str | None = None,
    colorspace: str | None = None,
    command_line: str = "",
    quiet: bool = False,
    progress=NO_PROGRESS,
    pose: dict | None = None,
    measure_export: bool = False,
    projection=None,
) -> tuple:
    """Bake ``env_path`` into the ``env_sh`` asset ``output`` (and companions); the asset as
    written, the summary, and the environment it was baked from: the map as read with the
    policies the asset records, its pixels unturned (a ``pose`` turns the SH) and its sun
    not extracted — what :func:`shbake.format.provenance.reload_source` reads back — so a
    scene's check measures the asset against the map without reading either again.

    ``pose``: a scene probe's ``{"position": [x, y, z], "rotation_deg": θ}``, recorded in
    the asset (``probe_position``, ``probe_rotation_deg``); the SH are turned by ``θ``
    (:mod:`shbake.envmap.turn`).

    ``exr_dir``: lat-long irradiance / tangent-irradiance EXRs of ``map_size``
    rows (``2 × map_size`` columns), half floats unless ``float_exr``, PNGs
    beside them with ``png``. ``exports``: engine exports, each in its
    folder beside the asset (:func:`export_folder`).
    ``report``: per-band energy, truncation and the error against brute force, the
    headline ``error`` that of what a consumer evaluates (:func:`headline_error`; with
    ``exports`` or ``measure_export``, the SH exports' 9 coefficients and lights).
    ``lights``/``light_tol``/``light_shape``: lights fitted with the SH to the irradiance
    (:func:`shbake.bakers.env_sh.bake_env_sh`). ``projection``: the map's
    :class:`~shbake.bakers.env_sh.Projection` at these settings, made earlier (a scene's
    plan), which the bake then does not make again.
    """
    irradiance_lmax = check_settings(lmax, irradiance_lmax, irradiance_sh, exports, lights,
                                     light_tol, extract_sun, window, light_shape)  # fmt: skip
    check_output_path(output)
    if exr_dir is not None:
        check_output_dir(exr_dir, "--exr-dir")
    for target in exports:
        check_output_dir(export_folder(output, target), "--export")
    map_rows = map_size if exr_dir is not None else None
    what = "--exr-dir maps" + (" and --report" if report else "")
    check_memory(project_memory(0, map_rows, False), f"{map_size}x{2 * map_size} {what}")
    environment = load_environment(env_path, layout, colorspace, negative, fix_nonfinite, quiet)
    h, w = environment.shape
    if report:
        what = f"--report over {w}x{h} texels" + (" and --exr-dir maps" if map_rows else "")
    if report or map_rows:
        check_memory(project_memory(h * w, map_rows, report), what)
    provenance = {"command_line": command_line}
    rotation = None
    if pose is not None:
        from shbake.envmap.turn import apply_pose

        rotation = apply_pose(environment, pose)
    asset, summary = bake_env_sh(
        environment,
        lmax=lmax,
        window_name=window,
        irradiance_lmax=irradiance_lmax,
        irradiance=irradiance_sh,
        tangent=tangent_irradiance,
        sun=extract_sun,
        sun_radius_deg=sun_radius,
        provenance=provenance,
        rotation=rotation,
        lights=lights,
        light_tol=light_tol,
        light_shape=light_shape,
        projection=projection,
    )
    maps = {}
    if exr_dir is not None:
        dirs = latlong_directions(map_size, 2 * map_size)
        if irradiance_sh:
            maps["irradiance.exr"] = shader(asset, "irradiance").irradiance(dirs)
        if tangent_irradiance:
            maps["tangent_irradiance.exr"] = shader(asset, "tangent-sh").irradiance(dirs)
        for name, img in maps.items():
            peak = float(np.abs(img).max())
            if not float_exr and peak > HALF_MAX:
                raise OutputError(f"{name}: value {peak:.6g} overflows half float; use --float-exr")
            to_float32(img, env_path, f"the --exr-dir map {name}")  # before any output
    if report:
        projected = environment
        if extract_sun and summary.get("sun", {}).get("extracted"):
            projected = sun_light.extract_sun(environment, radius_deg=sun_radius)[1]
        rep = truncation_report(projected, lmax, irradiance_lmax)
        from shbake.evaluation import env_sh as check  # --report alone (start-up)

        ref = check.brute_force_reference(environment, progress=progress)
        rep["error_vs_brute_force"] = check.irradiance_errors(asset, environment, ref)
        if irradiance_sh and (exports or measure_export):  # what the engines evaluate
            rep["error_vs_brute_force"]["export"] = check.export_irradiance_errors(
                asset, environment, ref)  # fmt: skip
        summary["report"] = rep
        summary["error"] = headline_error(rep["error_vs_brute_force"])

    write_asset(output, asset)
    written = [output]
    if maps:
        makedirs(exr_dir)
        for name, img in maps.items():
            path = os.path.join(exr_dir, name)
            write_exr(path, img, half=not float_exr, attrs={"envmap": 0})
            written.append(path)
            if png:
                png_path = os.path.splitext(path)[0] + ".png"
                write_png(png_path, tonemap_to_srgb8(img))
                written.append(png_path)
    glossy = [] if report else None  # the cube chains of gltf/babylon, as the engine reads them
    for target in exports:  # issue 14: the library call of `shbake export`
        folder = export_folder(output, target)
        makedirs(folder)
        out = os.path.join(folder, os.path.basename(os.path.splitext(output)[0]) + (
            ".json" if target == "threejs" else ".gltf"))  # fmt: skip
        from shbake.batch.export import export_assets  # the exporters load numba: only here

        files = export_assets([output], target, out, env_path=env_path,
                              sun_radius_deg=sun_radius, glossy_report=glossy)  # fmt: skip
        summary[target] = files[0]
        written.extend(files)
    summary.update(
        kind="env_sh",
        output=output,
        outputs=written,
        input=env_path,
        layout=environment.layout,
        negative_count=environment.meta["negative_count"],
        lighting_L00=asset["/lighting/sh"][0].tolist(),
    )
    lights_found = asset_lights(asset)
    if summary.get("sun", {}).get("extracted"):
        summary["sun"].update(lights_found[0])
    elif summary.get("lights"):
        summary["lights"]["lights"] = lights_found
    summary["warnings"] = quality_warnings(asset, summary)
    if glossy:
        summary["glossy"] = glossy
        summary["warnings"] += [w for chain in glossy for w in chain["warnings"]]
    return asset, summary, environment
