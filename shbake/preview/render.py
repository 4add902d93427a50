"""``preview`` as one unit of work: read an asset, render a pass (and its reference), write images.

:func:`preview_asset` reads the asset (and, for references, the original map
it records, hash-checked), renders the pass on a sphere
(:mod:`shbake.preview.passes`, :mod:`shbake.preview.glossy`), and writes the
float32 EXR of the pass, with ``diff`` the reference and the signed error as
EXRs too, and always a labelled contact sheet ``<stem>-sheet.png``
(:mod:`shbake.preview.contact_sheet`); ``png`` adds a plain tone-mapped PNG
beside every EXR. It never overwrites the source map.
"""

import os

import numpy as np

from shbake.conventions import ggx_alpha
from shbake.errors import ParameterError
from shbake.format.asset import read_asset
from shbake.format.images import auto_exposure, tonemap_to_srgb8, write_exr, write_png
from shbake.format.kautz_table import table_at
from shbake.format.provenance import reload_source
from shbake.format.shexp import probe_from_set
from shbake.preview.contact_sheet import write_contact_sheet
from shbake.preview.glossy import PASS_OF_KIND, render_glossy
from shbake.preview.passes import PASSES, render_pass
from shbake.preview.shrm import preview_shrm
from shbake.progress import NO_PROGRESS
from shbake.resources import check_memory

REFERENCE_OF = {"irradiance": "reference", "tangent": "reference-tangent", "kautz": "reference"}
ALL_PASSES = PASSES + tuple(PASS_OF_KIND.values()) + ("shrm",)

KIND_OPTIONS = {
    "table_path": "--table",
    "at": "--at",
    "merl_path": "--merl",
    "roughness": "--roughness",
    "alpha": "--alpha",
    "f0": "--f0",
    "samples": "--samples",
    "index": "--index",
}
"""Settings that only some asset kinds read, and the option that sets each."""


def options_of_kind(kind: str) -> frozenset:
    """The :data:`KIND_OPTIONS` an asset of ``kind`` reads: env_sh the Kautz table's
    (``--table``, ``--at``, ``--merl``), probes the glossy sphere's (``--roughness``/
    ``--alpha``, ``--f0``, ``--samples``; sets also ``--index``), shrm none."""
    if kind == "env_sh":
        return frozenset(("table_path", "at", "merl_path"))
    if kind == "shrm":
        return frozenset()
    probe = frozenset(("roughness", "alpha", "f0", "samples"))
    return probe | {"index"} if kind == "shexp_probe_set" else probe


PIXEL_BYTES = 256
"""Working memory per pixel of the ``size``² image, one pass: sphere geometry, the
float64 image, masks, tone mapping and the contact sheet (tracemalloc peaks of 192-212 B
at 256²-768², ``tests/test_faults.py::TestPreviewMemory``)."""
REFERENCE_PIXEL_BYTES = 96
"""Added per pixel by a second image (``--diff``): the reference and the signed error."""
COEFF_PIXEL_BYTES = 48
"""Added per pixel and SH coefficient by the kautz pass (local lighting and world-rotated
table coefficients, ``(P, n, 3)`` float64 each)."""
TEXEL_BYTES = 160
"""Per texel of the source map, for the brute-force reference: directions, solid angles,
radiance and their weighted copies (float64)."""


def preview_memory(size: int, reference: bool = False, coeffs: int = 0, texels: int = 0) -> int:
    """Estimated peak bytes of a preview of ``size``² pixels (``reference``: a second
    image; ``coeffs``: SH coefficients of a kautz table; ``texels``: of the source map
    a brute-force reference integrates)."""
    per_pixel = PIXEL_BYTES + COEFF_PIXEL_BYTES * coeffs
    per_pixel += REFERENCE_PIXEL_BYTES if reference else 0
    return int(size) * int(size) * per_pixel + TEXEL_BYTES * int(texels)


def check_preview_memory(size, reference=False, coeffs=0, source=None) -> None:
    """Refuse a preview whose :func:`preview_memory` exceeds the memory budget, before
    rendering (``source``: the loaded map of a reference pass, or ``None``)."""
    texels = 0 if source is None else source.shape[0] * source.shape[1]
    what = f"a {size}x{size} preview" + (" with its reference" if reference else "")
    check_memory(preview_memory(size, reference, coeffs, texels), what)


def _render_env(asset, asset_path, pass_name, size, diff, source, table_path, at, merl_path):
    pass_name = pass_name or "irradiance"
    if pass_name in PASS_OF_KIND.values():
        raise ParameterError(f"--pass {pass_name} needs a {pass_name}_probe asset")
    if pass_name == "kautz" and table_path is None:
        raise ParameterError("--pass kautz needs --table TABLE.h5")
    if diff and pass_name not in REFERENCE_OF:
        raise ParameterError("--diff needs the irradiance, tangent or kautz pass")
    table = brdf = None
    if table_path is not None:
        table = table_at(read_asset(table_path, kinds=("brdf_table",)),
                         {k: float(v) for k, v in (at or {}).items()})  # fmt: skip
    needs_source = pass_name.startswith("reference") or diff
    coeffs = table.coeffs.shape[-2] if pass_name == "kautz" else 0
    check_preview_memory(size, diff, coeffs)
    if table is not None and needs_source:
        brdf = table.make_brdf(merl_path)
    src = reload_source(asset, asset_path, source) if needs_source else None
    check_preview_memory(size, diff, coeffs, src)
    img, timing = render_pass(asset, pass_name, size, src, table, brdf)
    summary = {"pass": pass_name, "size": size, "seconds": timing["seconds"], "fps": timing["fps"]}
    if "modes" in timing:
        summary["modes"] = timing["modes"]
    settings = f"size {size}" + (f", table {os.path.basename(table_path)}" if table_path else "")
    reference = None
    if diff:
        reference, ref_timing = render_pass(asset, REFERENCE_OF[pass_name], size, src, None, brdf)
        summary["reference_seconds"] = ref_timing["seconds"]
    return img, reference, summary, settings, src


def _render_probe(asset, asset_path, pass_name, size, diff, source, roughness, f0, samples):
    own = PASS_OF_KIND[asset.kind]
    pass_name = pass_name or own
    if pass_name not in (own, "reference"):
        raise ParameterError(f"a {asset.kind} asset has passes {own} and reference")
    if diff and pass_name == "reference":
        raise ParameterError("--diff compares a probe pass with the reference")
    needs_source = pass_name == "reference" or diff
    check_preview_memory(size, diff)
    src = reload_source(asset, asset_path, source) if needs_source else None
    check_preview_memory(size, diff, 0, src)
    alpha = ggx_alpha(roughness)  # probes take the GGX width (probe format 2)
    img, timing = render_glossy(asset, pass_name, size, alpha, f0, src, samples)
    summary = {"pass": pass_name, "size": size, "roughness": roughness, "alpha": alpha, "f0": f0,
               "seconds": timing["seconds"], "fps": timing["fps"]}  # fmt: skip
    reference = None
    if diff:
        reference, ref_timing = render_glossy(asset, "reference", size, alpha, f0, src, samples)
        summary["reference_seconds"] = ref_timing["seconds"]
    settings = f"roughness {roughness:g} (α {alpha:.4g}), F0 {f0:g}, size {size}"
    return img, reference, summary, settings, src


def preview_asset(
    asset_path: str,
    output: str,
    pass_name: str | None = None,
    size: int = 192,
    diff: bool = False,
    source: str | None = None,
    table_path: str | None = None,
    at: dict | None = None,
    merl_path: str | None = None,
    roughness: float = 0.5,
    f0: float = 1.0,
    index: int = 0,
    samples: int = 4096,
    png: bool = False,
    progress=NO_PROGRESS,
    explicit=(),
) -> dict:
    """Render pass ``pass_name`` of the asset at ``asset_path`` into ``output`` (EXR); the summary.

    ``env_sh`` assets: irradiance, tangent, kautz (``table_path``) and their references;
    probe assets: their own pass or the glossy reference at ``roughness``, ``f0``.
    ``explicit``: names of the settings the caller set on purpose (the command line's);
    one of :data:`KIND_OPTIONS` that the asset's kind does not read raises
    :class:`~shbake.errors.ParameterError` rather than being ignored.
    """
    if pass_name is not None and pass_name not in ALL_PASSES:
        raise ParameterError(f"unknown pass {pass_name!r}; choose one of {', '.join(ALL_PASSES)}")
    asset = read_asset(asset_path, kinds=("env_sh", "shexp_probe_set", "shrm", *PASS_OF_KIND))
    reads = options_of_kind(asset.kind)
    stray = [o for k, o in KIND_OPTIONS.items() if k in explicit and k not in reads]
    if stray:
        raise ParameterError(f"{', '.join(stray)}: not read for a {asset.kind} asset")
    if asset.kind == "shexp_probe_set":
        asset = probe_from_set(asset, index)
    with progress.task(f"preview {os.path.basename(asset_path)}", total=None, unit="pass"):
        if asset.kind == "shrm":  # SHRM hook (issue 13): shbake.preview.shrm.preview_shrm
            needs_source = diff or pass_name == "reference"
            check_preview_memory(size, diff)
            src = reload_source(asset, asset_path, source) if needs_source else None
            check_preview_memory(size, diff, 0, src)
            img, reference, summary, settings = preview_shrm(asset, pass_name, size, diff, src)
        elif asset.kind in PASS_OF_KIND:
            img, reference, summary, settings, src = _render_probe(
                asset, asset_path, pass_name, size, diff, source, roughness, f0, samples
            )
        else:
            img, reference, summary, settings, src = _render_env(
                asset, asset_path, pass_name, size, diff, source, table_path, at, merl_path
            )
    title = f"{os.path.basename(asset_path)} ({asset.kind}): pass {summary['pass']}, {settings}"
    write_outputs(output, img, reference, summary, title, png, src)
    return summary


def write_outputs(output, img, reference, summary, title, png=False, source=None):
    """Write the pass EXR (and with a reference: the reference, the signed error, MSE and
    relative RMS error into ``summary``), the contact sheet and, with ``png``, plain PNGs.
    Refuses to overwrite the ``source`` map."""
    stem = os.path.splitext(output)[0]
    images = {output: img}
    subtitle = ""
    mask = np.any(img != 0.0, axis=-1)
    if reference is not None:
        mask = mask | np.any(reference != 0.0, axis=-1)
        err = img - reference
        mse = float(np.mean(err[mask] ** 2)) if mask.any() else 0.0
        rel = float(np.sqrt(np.sum(err**2) / max(np.sum(reference**2), 1e-300)))
        images[stem + "-reference.exr"] = reference
        images[stem + "-diff.exr"] = err
        summary.update(mse=mse, relative_rms_error=rel)
        subtitle = f"MSE {mse:.4g} (over sphere pixels and channels), relative RMS error {rel:.3%}"
    sheet = stem + "-sheet.png"
    written = list(images) + [sheet] + ([os.path.splitext(p)[0] + ".png" for p in images]
                                        if png else [])  # fmt: skip
    if source is not None:
        for path in written:
            if os.path.exists(path) and os.path.samefile(path, source.meta["path"]):
                raise ParameterError(f"{path} is the source map; choose another --output")
    exposure = auto_exposure(reference if reference is not None else img)
    for path, im in images.items():
        write_exr(path, im, half=False)
        if png:
            write_png(
                os.path.splitext(path)[0] + ".png",
                tonemap_to_srgb8(np.abs(im) if path.endswith("-diff.exr") else im, exposure),
            )
    write_contact_sheet(sheet, img, mask, title, reference, subtitle)
    summary["outputs"] = written
