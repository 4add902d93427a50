"""``shbake export``: env_sh (or split-sum) assets, or environment maps baked on the way,
→ engine-ready files (``docs/EXPORTS.md``)."""

import click
from click.core import ParameterSource
from shbake_cli.options import (
    FINITE,
    BarProgress,
    FiniteRange,
    also_wrote,
    emit_json,
    glossy_line,
    headline_line,
    info,
    input_policy_opts,
    json_opt,
    output_opt,
    quiet_opt,
    report_opt,
    samples_opt,
    usage_errors,
    warn,
)

from shbake.bakers.cube_chain import CUBE_SIZE_LIMIT
from shbake.bakers.env_lights import MAX_LIGHTS
from shbake.batch.export import cube_settings
from shbake.batch.export_map import MAP_DEFAULTS, export_inputs
from shbake.conventions import LMAX_LIMIT
from shbake.envmap.sun import SUN_RADIUS_DEG, SUN_RADIUS_MAX_DEG
from shbake.format.exports import TARGETS
from shbake.format.exports.cube_chain import LOD_MAPPINGS
from shbake.format.exports.gltf import BABYLON_SCENES
from shbake.format.exports.source import FRAMES
from shbake.sh.windows import WINDOW_METHODS


@click.command("export")
@click.argument("assets", metavar="INPUTS", nargs=-1, required=True,
                type=click.Path(dir_okay=False))  # fmt: skip
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
    default=SUN_RADIUS_DEG,
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
@click.option(
    "--lmax",
    type=click.IntRange(0, LMAX_LIMIT),
    default=None,
    help=f"Map input: highest SH band of the baked lighting [{MAP_DEFAULTS['lmax']}: every SH "
    "target reads the first 9 coefficients].",
)
@click.option(
    "--window",
    type=click.Choice(WINDOW_METHODS),
    default=None,
    help="Map input: band window before the irradiance kernels, as project-env's [none].",
)
@click.option(
    "--extract-sun/--no-extract-sun",
    default=None,
    help="Map input: take the dominant compact light out of the map as a directional light "
    "(where the map has one) [on].",
)
@click.option(
    "--lights",
    type=click.Choice(["auto"] + [str(k) for k in range(MAX_LIGHTS + 1)]),
    default=None,
    help="Map input: fit K directional lights with the SH to the irradiance, as project-env's; "
    "auto: the fewest meeting a 1 % mean error. Lights are what lowers an L2 export's error.",
)
@click.option(
    "--keep-asset",
    type=click.Path(dir_okay=False),
    default=None,
    help="Map input: also keep the baked env_sh asset here (otherwise none is left).",
)
@input_policy_opts
@report_opt
@json_opt
@quiet_opt
def export(assets, target, output, out_dir, sun_radius_deg, babylon_scene, as_json, quiet, **cube):
    """Export INPUTS to an engine format: env_sh assets (split-sum probes for ktx2), or
    environment maps (EXR, HDR, …), baked first into an env_sh asset as project-env would
    with the recommended settings (lmax 2, the sun extracted), measured against brute force.

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
    bake = {k: cube.pop(k) for k in ("lmax", "window", "extract_sun", "layout", "negative",
                                     "fix_nonfinite", "colorspace", "lights")}  # fmt: skip
    if bake["lights"] not in (None, "auto"):
        bake["lights"] = int(bake["lights"])
    ctx = click.get_current_context()
    explicit = {k for k in ctx.params if ctx.get_parameter_source(k) is ParameterSource.COMMANDLINE}
    result = export_inputs(
        list(assets),
        target,
        output if output is not None else out_dir,
        frame=cube["frame"],
        rotate_deg=cube["rotate_deg"],
        env_path=cube["env_path"],
        sun_radius_deg=sun_radius_deg,
        babylon_scene=babylon_scene,
        many=out_dir is not None,
        bake=bake,
        keep_asset=cube["keep_asset"],
        report=cube["report"],
        explicit=explicit,
        progress=BarProgress(quiet),
        **settings,
    )
    written = result["written"]
    for m in result["measured"]:
        info(f"{m['input']}: " + measured_line(m), quiet)
    for summary in result["bakes"]:
        info(bake_line(summary), quiet)
        for w in summary["warnings"]:
            warn(w, quiet)
    for chain in result["glossy"]:
        info(glossy_line(chain), quiet)
        for w in chain["warnings"]:
            warn(f"{chain['input']}: {w}", quiet)
    if as_json:
        emit_json({"target": target, "written": written, "bakes": result["bakes"],
                   "measured": result["measured"], "glossy": result["glossy"]})  # fmt: skip
    else:
        info(f"wrote {written[0]} ({target})" + also_wrote(written[1:]), quiet)


def measured_line(entry: dict) -> str:
    """An asset input's ``--report`` entry (:func:`shbake.batch.export_map.measure_asset`) on
    one line: the headline error of what the engine evaluates, a BRDF table's error (``webgl``)
    with its parts, a probe's or an SHRM's (``webgl``), or why nothing was measured."""
    error = entry["error"]
    if error is None:
        return f"not measured ({entry['kind']}: {entry['note']})"
    if "measure" in error:  # a probe's or an SHRM's (webgl)
        return f"error {error['value']:.2%} ({error['measure']}) of the {error['quantity']}"
    if entry.get("kind") != "brdf_table":
        return headline_line(error)
    return (f"error {error['value']:.2e} (relative L2 over the sphere, mean of {error['views']} "
            f"views) of the {error['quantity']}; parts: truncation at lmax {error['lmax']} "
            f"{error['truncation']:.2e}, coefficients (quadrature + bilinear look-up) "
            f"{error['coefficients']:.2e}")  # fmt: skip


def bake_line(summary: dict) -> str:
    """A map input's bake in one line: its settings and the headline error of the export."""
    sun = summary.get("sun", {})
    lights = summary.get("lights")
    light = ("the sun extracted" if sun.get("extracted") else
             f"{lights['count']} lights fitted" if lights else "no sun extracted")  # fmt: skip
    return (f"{summary['input']}: baked env_sh lmax {summary['lmax']} ({light}, window "
            f"{summary['window']}); " + headline_line(summary["error"]))  # fmt: skip
