"""``shbake export``: env_sh (or split-sum) assets → engine-ready files (``docs/EXPORTS.md``)."""

import click
from click.core import ParameterSource
from shbake_cli.options import (
    FINITE,
    FiniteRange,
    also_wrote,
    emit_json,
    info,
    json_opt,
    output_opt,
    quiet_opt,
    samples_opt,
    usage_errors,
)

from shbake.bakers.cube_prefilter import CUBE_SIZE_LIMIT, LOD_MAPPINGS
from shbake.batch.export import cube_settings, export_assets
from shbake.envmap.sun import SUN_RADIUS_MAX_DEG
from shbake.format.exports import TARGETS
from shbake.format.exports.gltf import BABYLON_SCENES
from shbake.format.exports.source import FRAMES


@click.command("export")
@click.argument("assets", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option(
    "--to", "target", required=True, type=click.Choice(sorted(TARGETS)), help="Engine / format."
)
@output_opt(
    "Output for one asset: FILE.gltf, FILE.env (babylon), FILE.json, FILE.ktx2 (ktx2, "
    "threejs-pmrem), STEM_sh.txt, FILE.unity.json, or the folder DIR (webgl: an earlier "
    "export there is replaced whole)",
    required=False,
    dir_okay=True,
)
@click.option(
    "--out-dir",
    type=click.Path(file_okay=False),
    default=None,
    help="Folder for several assets: one export per input, named after it.",
)
@click.option(
    "--frame",
    type=click.Choice(FRAMES),
    default="y-up",
    show_default=True,
    help="Up axis of the target scene (z-up: (x, y, z) -> (x, -z, y)).",
)
@click.option(
    "--rotate",
    "rotate_deg",
    type=FINITE,
    default=0.0,
    show_default=True,
    help="Turn the environment about the target's up axis, degrees counter-clockwise from above.",
)
@click.option(
    "--env",
    "env_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Source map of the cube maps [default: the path recorded in the asset].",
)
@click.option(
    "--size",
    type=int,
    default=None,
    help=f"Texels per side of the first cube mip, a power of two up to {CUBE_SIZE_LIMIT} "
    "[ktx2 128, others 256].",
)
@click.option(
    "--floor",
    type=int,
    default=None,
    help="Texels per side of the last cube mip, a power of two up to --size "
    "[ktx2 1, gltf/babylon 8, filament/threejs-pmrem 4].",
)
@click.option(
    "--lod-mapping",
    "mapping",
    type=click.Choice(LOD_MAPPINGS),
    default=None,
    help="Roughness of each mip level [gltf/babylon: babylon; ktx2: gltf-ibl-sampler; "
    "fixed for filament, threejs-pmrem].",
)
@samples_opt(None, "per cube texel, GGX with filtered importance sampling [512]")
@click.option(
    "--sun-radius",
    "sun_radius_deg",
    type=FiniteRange(0.0, SUN_RADIUS_MAX_DEG, min_open=True),
    default=10.0,
    show_default=True,
    help=f"Radius the asset's sun was extracted with, degrees (0…{SUN_RADIUS_MAX_DEG:g}], to "
    "rebuild its residual map.",
)
@click.option(
    "--babylon-scene",
    type=click.Choice(BABYLON_SCENES),
    default="left-handed",
    show_default=True,
    help="gltf/babylon: the handedness of the Babylon scene that loads the file.",
)
@json_opt
@quiet_opt
def export(assets, target, output, out_dir, sun_radius_deg, babylon_scene, as_json, quiet, **cube):
    """Export ASSETS (env_sh; split-sum probes for ktx2) to an engine format.

    Beside the main file: gltf/babylon FILE_specular_<mip>_<face>.png (babylon
    FILE.env: STEM_lights.gltf with a sun); ktx2
    FILE_dfg.ktx2 and FILE_dfg.exr; filament STEM_ibl.ktx, STEM_skybox.ktx (and
    STEM_sun.json). See docs/EXPORTS.md for each target's conventions.
    """
    if (output is None) == (out_dir is None):
        raise click.UsageError("give -o FILE (one asset) or --out-dir DIR (several)")
    if output is not None and len(assets) > 1:
        raise click.UsageError("several assets need --out-dir")
    settings = {k: cube[k] for k in ("size", "floor", "mapping", "samples") if cube[k] is not None}
    with usage_errors():
        cube_settings(target, **settings)
    ctx = click.get_current_context()
    explicit = {k for k in ctx.params if ctx.get_parameter_source(k) is ParameterSource.COMMANDLINE}
    written = export_assets(
        list(assets),
        target,
        output if output is not None else out_dir,
        frame=cube["frame"],
        rotate_deg=cube["rotate_deg"],
        env_path=cube["env_path"],
        sun_radius_deg=sun_radius_deg,
        babylon_scene=babylon_scene,
        many=out_dir is not None,
        explicit=explicit,
        **settings,
    )
    if as_json:
        emit_json({"target": target, "written": written})
    else:
        info(f"wrote {written[0]} ({target})" + also_wrote(written[1:]), quiet)
