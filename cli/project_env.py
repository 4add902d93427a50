"""``shbake project-env``: HDR environment map → SH lighting, irradiance, tangent irradiance."""

import os
import shlex
import sys

import click
import numpy as np
from shbake_cli.options import (
    colorspace_opt,
    emit_json,
    fix_nonfinite_opt,
    info,
    json_opt,
    layout_opt,
    lmax_opt,
    negative_opt,
    quiet_opt,
)

from shbake.bakers.env_sh import bake_env_sh, truncation_report
from shbake.conventions import check_lmax
from shbake.envmap import load_environment
from shbake.envmap.layouts import latlong_directions
from shbake.errors import OutputError
from shbake.evaluation.env_sh import irradiance_errors
from shbake.format.asset import write_asset
from shbake.format.atomic import check_writable_dir
from shbake.format.engine_export import write_gltf_json
from shbake.format.images import HALF_MAX, write_exr
from shbake.sh.windows import WINDOW_METHODS
from shbake.shading.env_sh import irradiance as sh_irradiance


def command_line(ctx: click.Context) -> str:
    """The command line as typed (``main`` passes argv), for provenance."""
    argv = (ctx.find_root().obj or {}).get("argv")
    if argv is None:
        argv = sys.argv[1:]
    return shlex.join(["shbake", *argv])


@click.command("project-env")
@click.argument("env", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Asset (.h5).")
@lmax_opt
@click.option(
    "--window",
    type=click.Choice(WINDOW_METHODS),
    default="none",
    show_default=True,
    help="Band window before the irradiance kernels; 'dering' = weakest window "
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
    type=int,
    default=None,
    help="Highest band of the irradiance SH [default: min(lmax, 2)].",
)
@click.option("--extract-sun", is_flag=True, help="Extract the dominant compact light first.")
@click.option(
    "--sun-radius",
    type=float,
    default=10.0,
    show_default=True,
    help="Largest angular radius of the extracted light, degrees.",
)
@click.option(
    "--exr-maps",
    type=click.Path(file_okay=False),
    default=None,
    help="Write irradiance / tangent-irradiance lat-long EXRs into this directory.",
)
@click.option(
    "--map-height",
    type=click.IntRange(2, 4096),
    default=128,
    show_default=True,
    help="Height of the --exr-maps images (width = 2 × height).",
)
@click.option("--float-exr", is_flag=True, help="Write float32 EXRs instead of half.")
@click.option(
    "--export",
    "exports",
    type=click.Choice(["gltf"]),
    multiple=True,
    help="Engine export beside the asset (gltf: EXT_lights_image_based JSON).",
)
@click.option(
    "--report",
    is_flag=True,
    help="Energy per band, truncation error, and error vs brute force on stderr.",
)
@layout_opt
@negative_opt
@fix_nonfinite_opt
@colorspace_opt
@json_opt
@quiet_opt
@click.pass_context
def project_env(
    ctx,
    env,
    output,
    lmax,
    window,
    irradiance,
    tangent_irradiance,
    irradiance_lmax,
    extract_sun,
    sun_radius,
    exr_maps,
    map_height,
    float_exr,
    exports,
    report,
    layout,
    negative,
    fix_nonfinite,
    colorspace,
    as_json,
    quiet,
):
    """Project the environment map ENV onto SH and write the asset OUTPUT.

    ENV: lat-long, cube strip or cross; EXR, HDR or any format OpenImageIO reads.
    """
    check_lmax(lmax)
    if irradiance_lmax is None:
        irradiance_lmax = min(lmax, 2)
    check_lmax(irradiance_lmax, "--irradiance-lmax", limit=lmax)
    check_writable_dir(output)
    if exr_maps is not None and os.path.exists(exr_maps) and not os.path.isdir(exr_maps):
        raise OutputError(f"{exr_maps}: exists and is not a directory")
    environment = load_environment(env, layout, colorspace, negative, fix_nonfinite, quiet)
    provenance = {"command_line": command_line(ctx)}
    asset, summary = bake_env_sh(
        environment,
        lmax=lmax,
        window_name=window,
        irradiance_lmax=irradiance_lmax,
        irradiance=irradiance,
        tangent=tangent_irradiance,
        sun=extract_sun,
        sun_radius_deg=sun_radius,
        provenance=provenance,
    )
    maps = {}
    if exr_maps is not None:
        dirs = latlong_directions(map_height, 2 * map_height)
        if irradiance:
            maps["irradiance.exr"] = sh_irradiance(asset, dirs)
        if tangent_irradiance:
            maps["tangent_irradiance.exr"] = sh_irradiance(asset, dirs, tangent=True)
        for name, img in maps.items():
            peak = float(np.abs(img).max())
            if not float_exr and peak > HALF_MAX:
                raise OutputError(f"{name}: value {peak:.6g} overflows half float; use --float-exr")
    if "gltf" in exports and (not irradiance or irradiance_lmax < 2):
        raise click.UsageError("--export gltf needs --irradiance with irradiance lmax >= 2")
    if report:
        summary["report"] = truncation_report(environment, lmax, irradiance_lmax)
        summary["report"]["error_vs_brute_force"] = irradiance_errors(asset, environment)

    write_asset(output, asset)
    if maps:
        os.makedirs(exr_maps, exist_ok=True)
        for name, img in maps.items():
            write_exr(os.path.join(exr_maps, name), img, half=not float_exr, attrs={"envmap": 0})
    if "gltf" in exports:
        gltf_path = os.path.splitext(output)[0] + ".gltf.json"
        write_gltf_json(gltf_path, asset["/irradiance/sh"][:9], os.path.basename(env))
        summary["gltf"] = gltf_path

    summary.update(
        output=output,
        input=env,
        layout=environment.layout,
        negative_count=environment.meta["negative_count"],
        lighting_L00=asset["/lighting/sh"][0].tolist(),
    )
    if report:
        _print_report(summary, quiet)
    if as_json:
        emit_json(summary)
    else:
        info(f"wrote {output} (lmax {lmax}, {environment.layout})", quiet)


def _print_report(summary: dict, quiet: bool) -> None:
    rep = summary["report"]
    info("band  energy (R, G, B)", quiet)
    for l, e in enumerate(rep["band_energy"]):
        info(f"{l:4d}  " + "  ".join(f"{v:.4g}" for v in e), quiet)
    info(
        "lighting energy captured: "
        + ", ".join(f"{v:.6f}" for v in rep["lighting_energy_captured"]),
        quiet,
    )
    for k in ("irradiance", "tangent_irradiance"):
        info(
            f"{k} energy lost beyond its lmax: "
            + ", ".join(f"{v:.3e}" for v in rep[f"{k}_energy_lost"]),
            quiet,
        )
    for k, v in rep["error_vs_brute_force"].items():
        info(f"{k} vs brute force: mean {v['mean']:.4%}, max {v['max']:.4%}", quiet)
    if "sun" in summary:
        s = summary["sun"]
        if s.get("extracted"):
            info(
                f"sun: contrast {s['contrast']:.1f}, energy fraction "
                + ", ".join(f"{v:.3f}" for v in s["energy_fraction"]),
                quiet,
            )
        else:
            info(f"sun: none extracted (peak/background contrast {s['contrast']:.1f})", quiet)
