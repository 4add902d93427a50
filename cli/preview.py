"""``shbake preview``: render an asset's shading pass to EXR + PNG, with brute-force diff."""

import os

import click
import numpy as np
from shbake_cli.options import emit_json, info, json_opt, quiet_opt

from shbake.errors import FormatError, ImageReadError
from shbake.format.asset import read_asset
from shbake.format.images import auto_exposure, tonemap_to_srgb8, write_exr, write_png
from shbake.preview.passes import PASSES, render_pass

REFERENCE_OF = {"irradiance": "reference", "tangent": "reference-tangent", "kautz": "reference"}


def load_source(asset, source_path):
    """The original map of an asset (its recorded path, or ``source_path``), hash-checked."""
    from shbake.envmap import load_environment
    from shbake.envmap.image_io import sha256_of

    path = source_path or asset.attrs.get("input_abspath") or asset.attrs.get("input_path")
    if not path or not os.path.exists(path):
        raise ImageReadError(f"original map {path!r} not found; give it with --source")
    if sha256_of(path) != asset.attrs.get("input_sha256"):
        raise FormatError(f"{path}: SHA-256 differs from the one recorded in the asset")
    a = asset.attrs
    return load_environment(
        path,
        a.get("input_layout"),
        None
        if a.get("input_colorspace_in") == a.get("input_colorspace")
        else a.get("input_colorspace_in"),
        a.get("input_negative_policy", "clamp"),
        None if a.get("input_nonfinite_policy") == "error" else a.get("input_nonfinite_policy"),
        quiet=True,
    )


@click.command("preview")
@click.argument("asset_path", metavar="ASSET", type=click.Path(dir_okay=False))
@click.option(
    "--pass",
    "pass_name",
    type=click.Choice(PASSES),
    default="irradiance",
    show_default=True,
    help="Shading pass to render.",
)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False),
    help="EXR path (float32); a tone-mapped PNG is written beside it.",
)
@click.option(
    "--size",
    type=click.IntRange(8, 4096),
    default=192,
    show_default=True,
    help="Image size in pixels (square).",
)
@click.option(
    "--diff",
    is_flag=True,
    help="Also render the brute-force reference; write the error image, print MSE.",
)
@click.option(
    "--source",
    type=click.Path(dir_okay=False),
    default=None,
    help="Original map (default: the path recorded in the asset).",
)
@click.option(
    "--table",
    "table_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="brdf_table asset: needed by --pass kautz; makes --pass reference use its BRDF.",
)
@click.option(
    "--at",
    "at",
    multiple=True,
    metavar="PARAM=VALUE",
    help="Parameter point of a table with --vary axes (nearest tabulated value).",
)
@click.option(
    "--merl",
    "merl_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="MERL file of a merl table (default: the recorded path).",
)
@json_opt
@quiet_opt
def preview(
    asset_path, pass_name, output, size, diff, source, table_path, at, merl_path, as_json, quiet
):
    """Render a sphere lit by ASSET (an env_sh asset) with one shading pass."""
    asset = read_asset(asset_path, kinds=("env_sh",))
    table = brdf = None
    if pass_name == "kautz" and table_path is None:
        raise click.UsageError("--pass kautz needs --table TABLE.h5")
    if table_path is not None:
        from shbake_cli.brdf_table import parse_params

        from shbake.brdf.table_asset import table_at

        table = table_at(
            read_asset(table_path, kinds=("brdf_table",)),
            {k: float(v) for k, v in parse_params(at).items()},
        )
    needs_source = pass_name.startswith("reference") or diff
    if table is not None and needs_source:
        brdf = table.make_brdf(merl_path)
    src = load_source(asset, source) if needs_source else None
    img, timing = render_pass(asset, pass_name, size, src, table, brdf)
    outputs = {output: img}
    summary = {"pass": pass_name, "size": size, "seconds": timing["seconds"], "fps": timing["fps"]}
    if "modes" in timing:
        summary["modes"] = timing["modes"]
        for mode, t in timing["modes"].items():
            info(f"kautz {mode}: {t['fps']:.1f} frames/s", quiet)
    stem = os.path.splitext(output)[0]
    exposure = auto_exposure(img)
    if diff:
        if pass_name not in REFERENCE_OF:
            raise click.UsageError(
                "--diff compares the irradiance or tangent pass with its reference"
            )
        ref, ref_timing = render_pass(asset, REFERENCE_OF[pass_name], size, src, None, brdf)
        err = img - ref
        mse = float(np.mean(err**2))
        rel = float(np.sqrt(np.sum(err**2) / max(np.sum(ref**2), 1e-300)))
        outputs[stem + "-reference.exr"] = ref
        outputs[stem + "-diff.exr"] = np.abs(err)
        summary.update(mse=mse, relative_rms_error=rel, reference_seconds=ref_timing["seconds"])
        info(f"{pass_name} vs brute force: MSE {mse:.6g}, relative RMS error {rel:.4%}", quiet)
    for path, im in outputs.items():
        write_exr(path, im, half=False)
        png = os.path.splitext(path)[0] + ".png"
        e = exposure * (8.0 if path.endswith("-diff.exr") else 1.0)
        write_png(png, tonemap_to_srgb8(im, e))
    summary["outputs"] = sorted(outputs)
    if as_json:
        emit_json(summary)
    else:
        info(f"wrote {output} ({pass_name}, {timing['fps']:.1f} frames/s)", quiet)
