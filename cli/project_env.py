"""``shbake project-env``: HDR environment map → SH lighting, irradiance, tangent irradiance."""

import click
from shbake_cli.options import (
    BarProgress,
    FiniteRange,
    also_wrote,
    command_line,
    deprecated,
    emit_json,
    exr_dir_opt,
    glossy_line,
    headline_line,
    info,
    input_policy_opts,
    json_opt,
    many_maps,
    many_maps_opts,
    output_opt,
    png_opt,
    quiet_opt,
    report_opt,
    run_many_maps,
    size_opt,
    tol_opt,
    usage_errors,
    warn,
)

from shbake.bakers.env_lights import AUTO_MAX_LIGHTS, MAX_LIGHTS, SHAPES
from shbake.batch.project_env import EXPORTS, check_settings, project_environment
from shbake.conventions import LMAX_LIMIT, n_coeffs
from shbake.envmap.sun import SUN_RADIUS_DEG, SUN_RADIUS_MAX_DEG
from shbake.sh.windows import WINDOW_METHODS


@click.command("project-env")
@click.argument("maps", nargs=-1, type=click.Path(dir_okay=False))
@output_opt("The env_sh asset (.h5) of one map", required=False)
@many_maps_opts
@click.option(
    "--lmax",
    type=click.IntRange(0, LMAX_LIMIT),
    default=2,
    show_default=True,
    help=f"Highest SH band l of /lighting/sh (0…{LMAX_LIMIT}); (lmax+1)^2 coefficients.",
)
@click.option(
    "--window",
    type=click.Choice(WINDOW_METHODS),
    default="none",
    show_default=True,
    help="Band window before the irradiance kernels; 'dering' = the weakest window "
    "that makes the reconstructions non-negative.",
)
@click.option(
    "--irradiance/--no-irradiance",
    default=True,
    show_default=True,
    help="Store Lambert irradiance SH (/irradiance/sh).",
)
@click.option(
    "--tangent-irradiance/--no-tangent-irradiance",
    default=True,
    show_default=True,
    help="Store Kajiya–Kay tangent irradiance (/tangent_irradiance/*).",
)
@click.option(
    "--irradiance-lmax",
    type=click.IntRange(0, LMAX_LIMIT),
    default=None,
    help="Highest band of the irradiance SH (≤ --lmax) [default: min(lmax, 2)].",
)
@click.option(
    "--extract-sun",
    is_flag=True,
    help="Take the dominant compact light out of the map as a directional light before "
    "projecting (map-domain; --lights 1 fits one light to the irradiance instead).",
)
@click.option(
    "--lights",
    type=click.Choice(["auto"] + [str(k) for k in range(MAX_LIGHTS + 1)]),
    default=None,
    help="Fit K lights (directional, or spheres: --light-shape) and the SH together by least "
    "squares on the irradiance "
    f"(0…{MAX_LIGHTS}); auto: the fewest (0…{AUTO_MAX_LIGHTS}) meeting --tol.",
)
@click.option(
    "--light-shape",
    type=click.Choice(SHAPES),
    default="point",
    show_default=True,
    help="With --lights: point (directional; what engine exports take) or sphere (each "
    "light a cap of fitted angular radius, for shbake's shaders: --to webgl).",
)
@tol_opt(
    "with --lights auto, the mean relative luminance error of SH + lights against brute force "
    "(4096 Fibonacci normals) to meet [default: 0.01]"
)
@click.option(
    "--sun-radius",
    type=FiniteRange(0.0, SUN_RADIUS_MAX_DEG, min_open=True),
    default=SUN_RADIUS_DEG,
    show_default=True,
    help=f"Largest angular radius of the extracted light, degrees (0…{SUN_RADIUS_MAX_DEG:g}].",
)
@exr_dir_opt("irradiance.exr and tangent_irradiance.exr, lat-long")
@size_opt(128, "Height of the --exr-dir lat-long maps (width = 2 × height)")
@click.option("--float-exr", is_flag=True, help="Write float32 EXRs instead of half floats.")
@png_opt
@click.option(
    "--export",
    "exports",
    type=click.Choice(EXPORTS),
    multiple=True,
    help="Engine export beside the asset, as `shbake export --to TARGET` (docs/EXPORTS.md).",
)
@report_opt
@input_policy_opts
@json_opt
@quiet_opt
@deprecated("--exr-maps", "exr_dir", "--exr-dir", type=click.Path(file_okay=False))
@deprecated("--map-height", "size", "--size", type=click.IntRange(2, 4096))
@click.pass_context
def project_env(ctx, maps, output, map_list, out_dir, n_jobs, exr_dir, size, as_json, quiet,
                **settings):  # fmt: skip
    """Project the environment map MAPS onto SH and write the env_sh asset OUTPUT; several
    MAPS (or --list, --out-dir): each to OUT_DIR/STEM.h5, in one process or --jobs workers.

    MAPS: lat-long, cube strip or cross; EXR, HDR or any format OpenImageIO reads.
    """
    lights = settings.pop("lights")
    tol = settings.pop("tol")
    if tol is not None and lights != "auto":
        raise click.UsageError("--tol applies to --lights auto only")
    settings["lights"] = None if lights is None else lights if lights == "auto" else int(lights)
    settings["light_tol"] = 0.01 if tol is None else tol
    with usage_errors():
        check_settings(settings["lmax"], settings["irradiance_lmax"], settings["irradiance"],
                       settings["exports"], settings["lights"], settings["light_tol"],
                       settings["extract_sun"], settings["window"],
                       settings["light_shape"])  # fmt: skip
    if many_maps(maps, output, map_list, out_dir, exr_dir=exr_dir,
                 export=settings["exports"], report=settings["report"]):  # fmt: skip
        settings |= {"irradiance_sh": settings.pop("irradiance"), "quiet": True,
                     "command_line": command_line(ctx)}  # fmt: skip
        run_many_maps("project-env", maps, map_list, out_dir, n_jobs, settings, as_json, quiet)
        return
    summary = project_environment(
        maps[0],
        output,
        exr_dir=exr_dir,
        map_size=size,
        irradiance_sh=settings.pop("irradiance"),
        command_line=command_line(ctx),
        progress=BarProgress(quiet),
        **settings,
    )
    if settings["report"]:
        print_report(summary, quiet)
    for w in summary["warnings"]:
        warn(w, quiet)
    if as_json:
        emit_json(summary)
    else:
        info(f"wrote {output} (lmax {settings['lmax']}, {summary['layout']})"
             + also_wrote(summary["outputs"][1:]), quiet)  # fmt: skip


def print_report(summary: dict, quiet: bool) -> None:
    """The ``--report`` tables on stderr, every fraction labelled."""
    rep = summary["report"]
    sun = summary.get("sun", {})
    after = " (after the sun was extracted)" if sun.get("extracted") else ""
    if summary.get("error"):
        info(headline_line(summary["error"]) + "; its parts below", quiet)
    info(f"cost: baked in {summary['bake_seconds']:.3g} s; {n_coeffs(summary['lmax'])} lighting "
         f"and {n_coeffs(summary['irradiance_lmax'])} irradiance SH coefficients per channel",
         quiet)  # fmt: skip
    info("band  energy Σ_m L_lm² (R, G, B)", quiet)
    for l, e in enumerate(rep["band_energy"]):
        info(f"{l:4d}  " + "  ".join(f"{v:.4g}" for v in e), quiet)
    info(
        f"fraction of ∫L² dω captured by lmax {summary['lmax']}{after} (R, G, B): "
        + ", ".join(f"{v:.6f}" for v in rep["lighting_energy_captured"]),
        quiet,
    )
    for k in ("irradiance", "tangent_irradiance"):
        info(
            f"fraction of the {k} energy lost beyond lmax {summary['irradiance_lmax']} "
            "(R, G, B): " + ", ".join(f"{v:.3e}" for v in rep[f"{k}_energy_lost"]),
            quiet,
        )
    for k, v in rep["error_vs_brute_force"].items():
        info(f"{k} vs brute force, relative: mean {v['mean']:.4%}, max {v['max']:.4%}", quiet)
    if sun.get("extracted"):
        info(
            f"sun: peak/background contrast {sun['contrast']:.1f}, fraction of ∫L dω moved "
            "into the light (R, G, B): " + ", ".join(f"{v:.3f}" for v in sun["energy_fraction"]),
            quiet,
        )
        info(light_line(sun), quiet)
    elif sun:
        info(f"sun: none extracted (peak/background contrast {sun['contrast']:.1f})", quiet)
    lights = summary.get("lights")
    if lights:
        for f in lights["tried"]:
            info(f"lights: {f['count']} fitted, irradiance vs brute force (fit normals) mean "
                 f"{f['mean_error']:.4%}, max {f['max_error']:.4%}", quiet)  # fmt: skip
        for light in lights.get("lights", []):
            info(light_line(light), quiet)
    for chain in summary.get("glossy", []):
        info(glossy_line(chain), quiet)


def light_line(light: dict) -> str:
    """One light (:func:`shbake.format.env_sh.asset_lights`) on one line."""
    d = ", ".join(f"{v:.3f}" for v in light["direction"])
    colour = ", ".join(f"{v:.3f}" for v in light["colour"])
    size = (f", angular radius {light['angular_radius_deg']:.2f}° (a sphere)"
            if "angular_radius_deg" in light else "")  # fmt: skip
    return (f"{light['name']}: direction ({d}){size}, "
            f"elevation {light['elevation_deg']:.1f}°, "
            f"azimuth {light['azimuth_deg']:.1f}° (lat-long u × 360°); colour ({colour}) "
            f"(R, G, B, luminance 1); intensity {light['intensity']:.4g} (luminance of the "
            "irradiance at normal incidence, the map's radiance unit × sr)")  # fmt: skip
