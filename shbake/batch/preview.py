"""``shbake preview`` as one unit of work: read an asset, render a pass (and its reference),
write images.

:func:`preview_asset` reads the asset (and, for references, the original map
it records, hash-checked: :func:`shbake.format.provenance.reload_source`, and a measured
BRDF's MERL file from ``--merl`` alone, its bytes read checked against the SHA-256 the
asset records of it: :func:`_merl_digest`), takes the pass's shader from the registry
(:func:`shbake.shading.shader.shader`: a pass is a technique of the asset's kind, or a
``reference`` pass — the ground truth of one), renders it on a sphere
(:mod:`shbake.preview.passes`), and writes the float32 EXR of the pass, with ``diff`` the
reference and the signed error as EXRs too, and always a labelled contact sheet
``<stem>-sheet.png`` (:mod:`shbake.preview.contact_sheet`); ``png`` adds a plain
tone-mapped PNG beside every EXR. It never overwrites the source map.
"""

import os

import numpy as np

from shbake.conventions import ggx_alpha
from shbake.envmap.turn import recorded_turn
from shbake.errors import ParameterError
from shbake.evaluation.metrics import mean_squared_error, relative_rms_error
from shbake.format.asset import read_asset
from shbake.format.brdf_table import table_at
from shbake.format.images import auto_exposure, tonemap_to_srgb8, write_exr, write_png
from shbake.format.provenance import reload_source
from shbake.format.shexp import probe_from_set
from shbake.preview.contact_sheet import beyond_scale, write_contact_sheet
from shbake.preview.passes import render_pass
from shbake.progress import NO_PROGRESS
from shbake.resources import check_memory, check_regular_file, path_arguments
from shbake.shading.shader import DEFAULT_OF_KIND, shader, shader_classes, shaders_of_kind

REFERENCE_PASSES = {"reference": None, "reference-tangent": "tangent"}
"""Reference passes → the technique whose ground truth they draw (``None``: the asset's
main technique — the Kautz table's BRDF when ``--table`` is given)."""
ALL_PASSES = tuple(n for n, c in shader_classes().items() if c.kinds) + tuple(REFERENCE_PASSES)
"""Every ``--pass``: the registry's techniques, then the reference passes."""
PREVIEW_KINDS = ("env_sh", "shexp_probe", "shexp_probe_set", "splitsum_probe", "shrm")
"""Asset kinds the preview reads (a probe set is shaded one probe at a time)."""

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
_PROBE_OPTIONS = frozenset(("roughness", "alpha", "f0", "samples"))
OPTIONS_OF_KIND = {
    "env_sh": frozenset(("table_path", "at", "merl_path")),
    "shrm": frozenset(("merl_path",)),
    "shexp_probe": _PROBE_OPTIONS,
    "splitsum_probe": _PROBE_OPTIONS,
    "shexp_probe_set": _PROBE_OPTIONS | {"index"},
}
"""The :data:`KIND_OPTIONS` an asset of each kind reads: env_sh the Kautz table's
(``--table``, ``--at``, ``--merl``), probes the glossy sphere's (``--roughness``/
``--alpha``, ``--f0``, ``--samples``; sets also ``--index``), shrm a measured BRDF's
``--merl``."""


def _measured(sh) -> bool:
    """Whether the ground truth of shader ``sh`` is a measured (MERL) BRDF: a Kautz table's
    or an SHRM's, whose MERL file only ``--merl`` names (docs/SECURITY.md §3)."""
    if sh.truth == "brdf":
        return sh.table.model == "merl"
    return sh.truth == "reflection" and sh.brdf()[0] == "merl"


def _merl_digest(measured, path: str, merl_path: str | None) -> str | None:
    """The SHA-256 that ``measured``, the Kautz table or SHRM at ``path``, records of the
    MERL file it was baked from (a table's ``source_sha256``, an SHRM's
    ``brdf_source_sha256``), which the bytes read from ``merl_path`` (``--merl``) must have
    (:func:`~shbake.brdf.model.make_brdf`), else the reference and its error figures would
    silently be another BRDF's. The path the asset records is never followed. An SHRM
    written before ``brdf_source_sha256`` records none (``None``): its ``--merl`` is read
    as given, unchecked."""
    if merl_path is None:
        raise ParameterError(f"{path}: a measured (merl) BRDF: give its MERL file with --merl "
                             f"(the path the asset records is not followed)")  # fmt: skip
    check_regular_file(merl_path, "--merl")
    key = "source_sha256" if measured.kind == "brdf_table" else "brdf_source_sha256"
    return measured.attrs.get(key)


PIXEL_BYTES = 256
"""Working memory per pixel of the ``size``² image, one pass: sphere geometry, the
float64 image, masks, tone mapping and the contact sheet (tracemalloc peaks of 192-212 B
at 256²-768², ``tests/system/faults/test_memory.py::TestPreviewMemory``)."""
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


def _main_technique(kind: str, companions: dict) -> str:
    """The technique a ``reference`` pass draws the truth of: the one that reads the
    companions given (a Kautz table), else the kind's default."""
    if companions:
        classes = shader_classes()
        for name in shaders_of_kind(kind):
            if len(classes[name].kinds) > 1:
                return name
    return DEFAULT_OF_KIND[kind]


def _material(sh, roughness: float, f0: float) -> tuple[dict, dict, str]:
    """What the shader reads of the sphere's material: ``(material, summary, text)``."""
    if "alpha" not in sh.material:
        return {}, {}, ""
    alpha = ggx_alpha(roughness)  # probes take the GGX width (probe format 2)
    material = sh.check(alpha=alpha, f0=f0)
    text = f"roughness {roughness:g} (α {alpha:.4g}), F0 {f0:g}"
    return material, {"roughness": roughness, "alpha": alpha, "f0": f0}, text


@path_arguments("asset_path", "output", "source", "table_path", "merl_path")
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
    display: str = "reinhard",
    progress=NO_PROGRESS,
    explicit=(),
) -> dict:
    """Render pass ``pass_name`` of the asset at ``asset_path`` into ``output`` (EXR); the summary.

    A pass is a technique of the registry that shades the asset's kind
    (:func:`~shbake.shading.shader.shaders_of_kind`; default: the kind's) or a reference
    pass (:data:`REFERENCE_PASSES`); ``diff`` adds the ground truth of the pass's technique.
    Probes are drawn as a GGX sphere of perceptual ``roughness`` and Schlick ``f0``;
    ``display``: the display transform of the sheet and PNGs
    (:data:`shbake.format.images.DISPLAY_TRANSFORMS`);
    ``table_path`` (``at``) is the Kautz pass's BRDF table.
    ``explicit``: names of the settings the caller set on purpose (the command line's);
    one of :data:`KIND_OPTIONS` that the asset's kind does not read raises
    :class:`~shbake.errors.ParameterError` rather than being ignored.
    """
    if pass_name is not None and pass_name not in ALL_PASSES:
        raise ParameterError(f"unknown pass {pass_name!r}; choose one of {', '.join(ALL_PASSES)}")
    asset = read_asset(asset_path, kinds=PREVIEW_KINDS)
    reads = OPTIONS_OF_KIND[asset.kind]
    stray = [o for k, o in KIND_OPTIONS.items() if k in explicit and k not in reads]
    if stray:
        raise ParameterError(f"{', '.join(stray)}: not read for a {asset.kind} asset")
    if asset.kind == "shexp_probe_set":
        asset = probe_from_set(asset, index)
    companions, table = {}, None
    if table_path is not None:
        table = read_asset(table_path, kinds=("brdf_table",))
        companions["table"] = table_at(table, {k: float(v) for k, v in (at or {}).items()})
    reference = pass_name in REFERENCE_PASSES
    if reference and diff:
        raise ParameterError("--diff compares a shading pass with its reference")
    if reference:
        technique = REFERENCE_PASSES[pass_name] or _main_technique(asset.kind, companions)
    else:
        technique = pass_name or DEFAULT_OF_KIND[asset.kind]
    techniques = shaders_of_kind(asset.kind)
    if technique not in techniques:
        refs = [r for r, t in REFERENCE_PASSES.items() if t is None or t in techniques]
        passes = [*techniques, *refs]
        raise ParameterError(f"a {asset.kind} asset has passes {', '.join(passes[:-1])} and "
                             f"{passes[-1]}; not {pass_name}")  # fmt: skip
    sh = shader(asset, technique, **companions)
    material, summary, text = _material(sh, roughness, f0)
    needs_source = reference or diff
    merl_sha256 = None
    if needs_source and _measured(sh):  # a Kautz table's BRDF, or an SHRM's
        measured = (table, table_path) if sh.truth == "brdf" else (asset, asset_path)
        merl_sha256 = _merl_digest(*measured, merl_path)
    coeffs = 0 if reference else sh.point_coeffs  # a reference pass runs no shader
    check_preview_memory(size, diff, coeffs)
    src = reload_source(asset, asset_path, source) if needs_source else None
    check_preview_memory(size, diff, coeffs, src)
    truth = {"samples": samples, "merl_path": merl_path, "merl_sha256": merl_sha256,
             "rotation": recorded_turn(asset)}  # fmt: skip
    name = pass_name or technique
    if reference:
        img, timing = render_pass(sh, size, material, src, progress, **truth)
    else:
        img, timing = render_pass(sh, size, material)
    ref = None
    if diff:
        ref, ref_timing = render_pass(sh, size, material, src, progress, **truth)
    summary = {"pass": name, "size": size, "asset": asset_path, "kind": asset.kind,
               "display": display, **summary, **timing}  # fmt: skip
    if diff:
        summary["reference_seconds"] = ref_timing["seconds"]
    settings = ", ".join(x for x in (sh.label(), text, f"size {size}") if x)
    title = f"{os.path.basename(asset_path)} ({asset.kind}): pass {name}, {settings}"
    write_outputs(output, img, ref, summary, title, png, src, display)
    return summary


def write_outputs(output, img, reference, summary, title, png=False, source=None,
                  display="reinhard"):  # fmt: skip
    """Write the pass EXR (and with a reference: the reference, the signed error, MSE,
    relative RMS error and the fraction of pixels beyond the sheet's error scale into
    ``summary``), the contact sheet (with the ``source`` map's thumbnail) and, with ``png``,
    plain PNGs, through the ``display`` transform. Refuses to overwrite the ``source`` map."""
    stem = os.path.splitext(output)[0]
    images = {output: img}
    subtitle = ""
    mask = np.any(img != 0.0, axis=-1)
    if reference is not None:
        mask = mask | np.any(reference != 0.0, axis=-1)
        err = img - reference
        mse = mean_squared_error(img[mask], reference[mask])
        rel = relative_rms_error(img, reference)
        images[stem + "-reference.exr"] = reference
        images[stem + "-diff.exr"] = err
        summary.update(mse=mse, relative_rms_error=rel,
                       error_beyond_scale=beyond_scale(img, reference, mask))  # fmt: skip
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
                tonemap_to_srgb8(
                    np.abs(im) if path.endswith("-diff.exr") else im, exposure, display
                ),
            )
    write_contact_sheet(sheet, img, mask, title, reference, subtitle, display=display,
                        source=None if source is None else source.pixels)  # fmt: skip
    summary["outputs"] = written
