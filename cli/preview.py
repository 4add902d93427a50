"""``shbake preview``: render an asset's shading pass to EXR + PNG, with brute-force diff."""

import os

import click
import numpy as np
from shbake_cli.options import emit_json, info, json_opt, quiet_opt

from shbake.format.asset import read_asset
from shbake.format.images import auto_exposure, tonemap_to_srgb8, write_exr, write_png
from shbake.format.shexp import probe_from_set
from shbake.preview.glossy import PASS_OF_KIND, render_glossy
from shbake.preview.passes import PASSES, render_pass

REFERENCE_OF = {"irradiance": "reference", "tangent": "reference-tangent", "kautz": "reference"}
ALL_PASSES = PASSES + ("shexp", "splitsum")


def load_source(asset, asset_path, source_path):
    """The map an asset was baked from: ``--source``, else its ``source_path`` relative to
    the asset; SHA-256-checked, loaded with the asset's recorded policies."""
    from shbake.envmap import load_environment
    from shbake.format.provenance import resolve_source

    a = asset.attrs
    path = resolve_source(a, asset_path, source_path)
    cs_in = a.get("source_colorspace_in")
    nonfinite = a.get("source_nonfinite_policy")
    return load_environment(
        path,
        a.get("source_layout"),
        None if cs_in in (None, a.get("source_colorspace")) else cs_in,
        a.get("source_negative_policy") or "clamp",
        None if nonfinite in (None, "", "error") else nonfinite,
        quiet=True,
    )


@click.command("preview")
@click.argument("asset_path", metavar="ASSET", type=click.Path(dir_okay=False))
@click.option(
    "--pass",
    "pass_name",
    type=click.Choice(ALL_PASSES),
    default=None,
    help="Shading pass [default: irradiance; shexp or splitsum for probes]. "
    "reference: brute force of the asset's kind.",
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
    help="Original map (default: the source_path recorded in the asset, relative to it).",
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
@click.option(
    "--roughness",
    type=float,
    default=0.5,
    show_default=True,
    help="Probes: perceptual roughness of the sphere (within the probe's range).",
)
@click.option(
    "--f0",
    type=click.FloatRange(0.0, 1.0),
    default=1.0,
    show_default=True,
    help="Probes: Schlick F0 of the sphere (1 chrome, 0.04 dielectric).",
)
@click.option(
    "--index",
    type=int,
    default=0,
    show_default=True,
    help="Probe sets: which probe (list order).",
)
@click.option(
    "--samples",
    type=click.IntRange(16, 1 << 20),
    default=4096,
    show_default=True,
    help="Probes: ground-truth samples per pixel of the reference pass.",
)
@json_opt
@quiet_opt
def preview(
    asset_path, pass_name, output, size, diff, source, table_path, at, merl_path,
    roughness, f0, index, samples, as_json, quiet,
):  # fmt: skip
    """Render a sphere lit by ASSET with one shading pass.

    env_sh assets: irradiance, tangent, kautz and their references. Probe
    assets (shexp_probe, shexp_probe_set with --index, splitsum_probe): a GGX
    sphere of --roughness and --f0 shaded by the probe, or the glossy reference.
    """
    asset = read_asset(asset_path, kinds=("env_sh", "shexp_probe_set", *PASS_OF_KIND))
    if asset.kind == "shexp_probe_set":
        asset = probe_from_set(asset, index)
    if asset.kind in PASS_OF_KIND:
        preview_probe(asset, asset_path, pass_name, output, size, diff, source, roughness, f0,
                      samples, as_json, quiet)  # fmt: skip
        return
    pass_name = pass_name or "irradiance"
    if pass_name in PASS_OF_KIND.values():
        raise click.UsageError(f"--pass {pass_name} needs a {pass_name}_probe asset")
    table = brdf = None
    if pass_name == "kautz" and table_path is None:
        raise click.UsageError("--pass kautz needs --table TABLE.h5")
    if table_path is not None:
        from shbake_cli.brdf_table import parse_params

        from shbake.format.kautz_table import table_at

        table = table_at(
            read_asset(table_path, kinds=("brdf_table",)),
            {k: float(v) for k, v in parse_params(at).items()},
        )
    needs_source = pass_name.startswith("reference") or diff
    if table is not None and needs_source:
        brdf = table.make_brdf(merl_path)
    src = load_source(asset, asset_path, source) if needs_source else None
    img, timing = render_pass(asset, pass_name, size, src, table, brdf)
    summary = {"pass": pass_name, "size": size, "seconds": timing["seconds"], "fps": timing["fps"]}
    if "modes" in timing:
        summary["modes"] = timing["modes"]
        for mode, t in timing["modes"].items():
            info(f"kautz {mode}: {t['fps']:.1f} frames/s", quiet)
    reference = None
    if diff:
        if pass_name not in REFERENCE_OF:
            raise click.UsageError(
                "--diff compares the irradiance or tangent pass with its reference"
            )
        reference, ref_timing = render_pass(asset, REFERENCE_OF[pass_name], size, src, None, brdf)
        summary["reference_seconds"] = ref_timing["seconds"]
    write_outputs(output, img, reference, summary, as_json, quiet, src)


def preview_probe(asset, asset_path, pass_name, output, size, diff, source, roughness, f0,
                  samples, as_json, quiet):  # fmt: skip
    """The glossy passes of a probe asset (:mod:`shbake.preview.glossy`)."""
    own = PASS_OF_KIND[asset.kind]
    pass_name = pass_name or own
    if pass_name not in (own, "reference"):
        raise click.UsageError(f"a {asset.kind} asset has passes {own} and reference")
    if diff and pass_name == "reference":
        raise click.UsageError("--diff compares a probe pass with the reference")
    needs_source = pass_name == "reference" or diff
    src = load_source(asset, asset_path, source) if needs_source else None
    img, timing = render_glossy(asset, pass_name, size, roughness, f0, src, samples)
    summary = {"pass": pass_name, "size": size, "roughness": roughness, "f0": f0,
               "seconds": timing["seconds"], "fps": timing["fps"]}  # fmt: skip
    reference = None
    if diff:
        reference, ref_timing = render_glossy(asset, "reference", size, roughness, f0, src, samples)
        summary["reference_seconds"] = ref_timing["seconds"]
    write_outputs(output, img, reference, summary, as_json, quiet, src)


def write_outputs(output, img, reference, summary, as_json, quiet, source=None):
    """Write the pass (EXR + PNG) and, with a reference, the reference and the error image
    (MSE and relative RMS error into ``summary``); then report. Refuses to overwrite
    the ``source`` map."""
    pass_name = summary["pass"]
    stem = os.path.splitext(output)[0]
    exposure = auto_exposure(img)
    outputs = {output: img}
    if reference is not None:
        err = img - reference
        mse = float(np.mean(err**2))
        rel = float(np.sqrt(np.sum(err**2) / max(np.sum(reference**2), 1e-300)))
        outputs[stem + "-reference.exr"] = reference
        outputs[stem + "-diff.exr"] = np.abs(err)
        summary.update(mse=mse, relative_rms_error=rel)
        info(f"{pass_name} vs brute force: MSE {mse:.6g}, relative RMS error {rel:.4%}", quiet)
    written = [p for path in outputs for p in (path, os.path.splitext(path)[0] + ".png")]
    if source is not None:
        for path in written:
            if os.path.exists(path) and os.path.samefile(path, source.meta["path"]):
                raise click.UsageError(f"{path} is the source map; choose another --output")
    for path, im in outputs.items():
        write_exr(path, im, half=False)
        png = os.path.splitext(path)[0] + ".png"
        e = exposure * (8.0 if path.endswith("-diff.exr") else 1.0)
        write_png(png, tonemap_to_srgb8(im, e))
    summary["outputs"] = sorted(outputs)
    if as_json:
        emit_json(summary)
    else:
        info(f"wrote {output} ({pass_name}, {summary['fps']:.1f} frames/s)", quiet)
