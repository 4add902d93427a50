"""``shbake export``: env_sh assets → engine-ready files (``docs/EXPORTS.md``)."""

import click
from shbake_cli.options import emit_json, info, json_opt, quiet_opt

from shbake.batch.export import export_assets
from shbake.format.exports import TARGETS
from shbake.format.exports.source import FRAMES

frame_opt = click.option(
    "--frame",
    type=click.Choice(FRAMES),
    default="y-up",
    show_default=True,
    help="Up axis of the target scene (z-up: (x, y, z) -> (x, -z, y)).",
)
rotate_opt = click.option(
    "--rotate",
    "rotate_deg",
    type=float,
    default=0.0,
    show_default=True,
    help="Turn the environment about the target's up axis, degrees counter-clockwise from above.",
)


@click.command("export")
@click.argument("assets", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option(
    "--to", "target", required=True, type=click.Choice(sorted(TARGETS)), help="Engine / format."
)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(),
    help="Output file (a directory for several assets).",
)
@frame_opt
@rotate_opt
@click.option(
    "--env",
    "env_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Source map for cube maps [default: the path recorded in the asset].",
)
@click.option(
    "--size",
    type=int,
    default=None,
    help="Edge of the first cube mip, a power of two [gltf 64, ktx2/filament 128].",
)
@click.option(
    "--floor",
    type=int,
    default=None,
    help="Edge of the last cube mip, a power of two [gltf 8, ktx2/filament 1].",
)
@click.option(
    "--lod-mapping",
    "mapping",
    type=click.Choice(["gltf-ibl-sampler", "filament"]),
    default=None,
    help="Roughness of each mip level [gltf-ibl-sampler; filament for --to filament].",
)
@click.option(
    "--samples",
    type=int,
    default=None,
    help="GGX samples per texel, filtered importance sampling [gltf 256, others 512].",
)
@click.option(
    "--sun-radius",
    type=float,
    default=10.0,
    show_default=True,
    help="Radius the asset's sun was extracted with, degrees (to rebuild its residual map).",
)
@click.option(
    "--babylon-scene",
    type=click.Choice(["left-handed", "right-handed"]),
    default="left-handed",
    show_default=True,
    help="gltf/babylon: the handedness of the Babylon scene that loads the file.",
)
@json_opt
@quiet_opt
def export(
    assets,
    target,
    output,
    frame,
    rotate_deg,
    env_path,
    size,
    floor,
    mapping,
    samples,
    sun_radius,
    babylon_scene,
    as_json,
    quiet,
):
    """Export env_sh ASSETS to an engine format (docs/EXPORTS.md).

    Output names: gltf/babylon FILE.gltf (+ PNGs), threejs FILE.json, ktx2 FILE.ktx2
    (+ FILE_dfg.ktx2/.exr), filament STEM_sh.txt (+ STEM_ibl.ktx, STEM_skybox.ktx),
    unity FILE.unity.json.
    """
    given = {"size": size, "floor": floor, "mapping": mapping, "samples": samples}
    written = export_assets(
        list(assets),
        target,
        output,
        frame=frame,
        rotate_deg=rotate_deg,
        env_path=env_path,
        sun_radius_deg=sun_radius,
        babylon_scene=babylon_scene,
        **{k: v for k, v in given.items() if v is not None},  # else each target's defaults
    )
    if as_json:
        emit_json({"target": target, "written": written})
    else:
        info(f"wrote {len(written)} file(s) for {target}: {written[0]}", quiet)
