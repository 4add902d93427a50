"""``brdf-table`` as one unit of work: tabulate a BRDF, write the asset and its images.

:func:`bake_brdf_table` validates the model, parameters, axes and outputs
before any work, tabulates (:mod:`shbake.brdf.tabulate`), writes the
``brdf_table`` asset (:mod:`shbake.format.brdf_table`), the band EXRs and the
Kautz et al. Fig. 2 sheet, and with ``report`` measures error and time against
lmax, resolution and samples (:mod:`shbake.bakers.brdf_table_report`).
"""

import os

import numpy as np

from shbake.bakers.brdf_table_report import probe_views, product_energy, settings_report
from shbake.brdf import make_brdf, model_spec
from shbake.brdf.tabulate import parse_vary, project_views, quadrant_views, tabulate_axes
from shbake.conventions import KAUTZ_LMAX_LIMIT, check_lmax
from shbake.format.asset import write_asset
from shbake.format.atomic import check_output_dir, check_output_path, makedirs
from shbake.format.brdf_table import build_table_asset, table_at
from shbake.format.kautz_images import write_band_exrs, write_sheet
from shbake.progress import NO_PROGRESS
from shbake.resources import path_arguments


def check_parameters(model: str, params: dict, vary: tuple[str, ...] = ()) -> None:
    """``model``'s parameter values and every point of the ``vary`` axes checked by the
    model's own ranges (:meth:`~shbake.brdf.spec.ModelSpec.resolve`) without reading a
    file: the command line's usage check (a :class:`~shbake.errors.ParameterError`)."""
    spec = model_spec(model)
    spec.resolve(params)
    axes = [parse_vary(v) for v in vary]
    spec.check_axes([name for name, _ in axes])
    for name, values in axes:
        for value in values:
            spec.resolve(params | {name: value})


TABLE_ERROR_VIEWS = (32, 23)
"""Count and seed of the :func:`~shbake.bakers.brdf_table_report.probe_views` a written table's
error is measured at (none of them a texel centre)."""
ENERGY_NODES = 256
"""Gauss–Legendre nodes in θ of :func:`~shbake.bakers.brdf_table_report.product_energy` for
:func:`table_error`."""


def table_error(brdf, table: np.ndarray, lmax: int, reference_samples: int) -> dict:
    """The error of what a consumer of ``table`` (``(H, W, n, C)``) evaluates: ``f*(·, v)``
    rebuilt from the bilinear look-up ``c(v)`` against ``f*`` itself, relative L2 over the
    sphere, mean over the :data:`TABLE_ERROR_VIEWS` views (``error``,
    :func:`~shbake.evaluation.metrics.mean_relative_norm`); parts, each the same mean:
    ``truncation`` (Parseval: ``∫ f*² − Σ c_ref²``, ``c_ref`` projected at
    ``reference_samples`` points per strategy) and ``coefficients`` (``|c(v) − c_ref(v)|``:
    the table's quadrature noise and its bilinear look-up); per view ``error² =
    truncation² + coefficients²``."""
    from shbake.evaluation.metrics import mean_relative_norm
    from shbake.texture.parabolic import fetch

    views = probe_views(*TABLE_ERROR_VIEWS)
    energy = product_energy(brdf, views, ENERGY_NODES).sum(axis=1)
    ref, _ = project_views(brdf, views, lmax, samples=reference_samples)
    got = fetch(np.asarray(table), views)
    trunc2 = np.clip(energy - np.sum(ref * ref, axis=(1, 2)), 0, None)
    coeff2 = np.sum((got - ref) ** 2, axis=(1, 2))
    return {"error": mean_relative_norm(trunc2 + coeff2, energy),
            "truncation": mean_relative_norm(trunc2, energy),
            "coefficients": mean_relative_norm(coeff2, energy),
            "views": len(views)}  # fmt: skip


def written_table_error(asset) -> dict | None:
    """:func:`table_error` of a ``brdf_table`` asset as read back, at the parameter point its
    consumers take unless told (each axis's first value,
    :func:`~shbake.format.brdf_table.table_at`), the BRDF rebuilt from the asset's record:
    the headline ``brdf-table`` printed when it wrote the asset, with the table's ``lmax``.
    ``None`` for a measured (``merl``) BRDF: the MERL file the asset records is not read (an
    asset makes shbake read no file but its hash-checked source map, docs/SECURITY.md §3)."""
    from shbake.batch.plan import REFERENCE_SAMPLES  # the scene bake's reference (start-up)

    table = table_at(asset)
    if table.model == "merl":
        return None
    errors = table_error(table.make_brdf(), table.coeffs, table.lmax, REFERENCE_SAMPLES)
    return errors | {"lmax": table.lmax}


@path_arguments("output", "merl_path", "exr_dir")
def bake_brdf_table(
    model: str,
    output: str,
    params: dict | None = None,
    merl_path: str | None = None,
    lmax: int = 4,
    size: tuple[int, int] = (128, 128),
    samples: int = 1024,
    tol: float | None = None,
    max_samples: int = 1 << 18,
    vary: tuple[str, ...] = (),
    exr_dir: str | None = None,
    png: bool = False,
    report: bool = False,
    reproducible: bool = False,
    command_line: str = "",
    progress=NO_PROGRESS,
) -> dict:
    """Tabulate ``model`` into ``output``; the summary (with ``warnings`` to show the user).

    ``samples``: quadrature points per strategy (ignored with ``tol``, which
    refines each texel until its error estimate is at most ``tol`` or
    ``max_samples`` is reached; ``max_samples`` in
    [:data:`~shbake.brdf.tabulate.FIRST_LEVEL_POINTS`,
    :data:`~shbake.brdf.tabulate.MAX_SAMPLES_LIMIT`]). ``exr_dir``: the band EXRs and the
    Fig. 2 sheet, with ``png`` a PNG beside every EXR.
    """
    lmax = check_lmax(lmax, limit=KAUTZ_LMAX_LIMIT)
    brdf = make_brdf(model, merl_path=merl_path, **(params or {}))
    axes = [parse_vary(v) for v in vary]
    check_output_path(output)
    if exr_dir is not None:
        check_output_dir(exr_dir, "--exr-dir")
    points = 1
    for _, values in axes:
        points *= len(values)
    views = len(quadrant_views(*size)) * points
    what = "tabulating" + (f" {points} tables" if points > 1 else "")
    with progress.task(what, total=views, unit="view") as advance:
        tables, convs = tabulate_axes(
            brdf,
            axes,
            advance=advance,
            lmax=lmax,
            resolution=size,
            samples=None if tol is not None else samples,
            tol=tol,
            max_samples=max_samples,
        )
    asset = build_table_asset(brdf, tables, convs, axes, lmax, record_time=not reproducible)
    asset.attrs["command_line"] = command_line
    tattrs = asset.dataset_attrs["/table"]
    err = tattrs["error_estimate"]
    spec = brdf.spec
    fixed = {t for name in params or {} for t in spec.targets(name)}
    warnings = [f"-p {t} is replaced by the --vary {name} axis"
                for name, _ in axes for t in spec.targets(name) if t in fixed]  # fmt: skip
    if tol is not None and err > tol:
        bad = int(sum((c.view_errors > tol).sum() for c in convs))
        # every view integrates the nested rules' first level whole: a grazing view's lobe
        # rule cut at many steps can exceed --max-samples there
        used = max(max_samples, *(c.samples for c in convs))
        warnings.append(
            f"{bad} texels did not reach --tol {tol:g} by {used} samples (largest error "
            f"estimate {err:.2e}, per texel in /error); raise --max-samples above {used}"
        )
    if not tattrs["energy_conserving"]:
        warnings.append(
            f"measured albedo up to {max(tattrs['max_albedo']):.4f} > 1: these parameters do "
            "not conserve energy (flagged in the asset)"
        )
    from shbake.batch.plan import REFERENCE_SAMPLES  # the scene bake's reference (start-up)

    # the headline: what a consumer evaluates, at the first point of every --vary axis
    # (table_at's default)
    first = brdf.with_values(**{name: values[0] for name, values in axes})
    headline = table_error(first, table_at(asset).coeffs, lmax, REFERENCE_SAMPLES)
    summary = {
        "output": output,
        "model": model,
        "error": headline["error"],
        "error_parts": {
            "truncation": headline["truncation"],
            "coefficients": headline["coefficients"],
            "quadrature_estimate": err,
            "views": headline["views"],
        },
        "parameters": brdf.describe()["parameters"],
        "lmax": lmax,
        "size": list(size),
        "shape": list(asset["/table"].shape),
        "error_estimate": err,
        "samples_max": tattrs["samples_max"],
        "seconds": sum(c.seconds for c in convs),
        "max_albedo": tattrs["max_albedo"],
        "energy_conserving": tattrs["energy_conserving"],
        "warnings": warnings,
    }
    if report:
        summary["report"] = settings_report(
            brdf, lmax, size, samples if tol is None else convs[0].samples, convs[0].history,
            summary["seconds"],
        )  # fmt: skip
    write_asset(output, asset)
    if exr_dir is not None:
        makedirs(exr_dir)
        point = table_at(asset)
        written = write_band_exrs(exr_dir, point.coeffs, lmax, brdf.coloured, png=png)
        sheet_path = os.path.join(exr_dir, "sheet.png")
        write_sheet(sheet_path, point.coeffs, lmax)
        summary["images"] = written + [sheet_path]
    return summary
