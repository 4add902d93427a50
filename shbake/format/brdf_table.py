"""The ``brdf_table`` asset (``docs/FORMAT.md`` §3): build it, read it, look it up.

``/table`` is float32 with axes ``([channel,] *parameter axes, row, col, coeff)``:
a leading channel axis of 3 only for RGB BRDFs, then one axis per ``--vary``
parameter, then the parabolic map (SPEC §4) and the ``(lmax+1)^2`` SH
coefficients of ``f*(·, v)``. The axes are named in the ``axes`` attribute.
"""

import json
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from shbake.conventions import KAUTZ_LMAX_LIMIT, SQRT_4PI, lmax_of
from shbake.errors import FormatError, ParameterError
from shbake.format.asset import Asset
from shbake.format.provenance import file_source, no_source
from shbake.format.registry import MEANING_ATTR, Attr, Data, Kind, register

if TYPE_CHECKING:
    from shbake.brdf.model import BRDF

ENERGY_SLACK = 1e-3
"""Measured albedo above ``1 + ENERGY_SLACK`` flags a table as not energy-conserving."""

PARAMETERISATION = (
    "parabolic (Heidrich-Seidel 1999): p=(x,y)/(1+z), u=(p_x+1)/2 cols, w=(p_y+1)/2 rows"
)


def build_table_asset(
    brdf: "BRDF",
    tables: np.ndarray,
    convs: list,
    vary: list[tuple[str, np.ndarray]],
    lmax: int,
    record_time: bool = True,
) -> Asset:
    """Assemble the asset from :func:`~shbake.brdf.tabulate.tabulate_axes` output.

    ``tables`` is ``(*axes, H, W, n, 3)``. Returns an :class:`Asset` whose
    attributes record the model, parameters, quadrature error and (unless
    ``record_time`` is false, for byte-identical rebuilds) the bake time.
    """
    coloured = brdf.coloured
    axes = [name for name, _ in vary]
    data = np.moveaxis(tables, -1, 0) if coloured else tables[..., 0]
    names = (["channel"] if coloured else []) + axes + ["row", "col", "coeff"]
    shape_axes = tuple(len(v) for _, v in vary)
    h, w = tables.shape[len(vary) : len(vary) + 2]
    err_map = np.stack([c.view_errors for c in convs]).reshape(shape_axes + (h, w))
    albedo = SQRT_4PI * tables[..., 0, :]  # white-furnace value per view, channel
    max_albedo = albedo.reshape(-1, 3).max(axis=0)
    conserving = bool(np.all(max_albedo <= 1.0 + ENERGY_SLACK))
    table_attrs = {
        "axes": names,
        "lmax": lmax,
        "parameterisation": PARAMETERISATION,
        "view_z_min": _view_z_min(),
        "error_estimate": float(max(c.error for c in convs)),
        "error_definition": "sqrt(4*pi) * max |c(N) - c(N/2)| over coefficients and channels; "
                            "with --tol sqrt(4*pi) * max sum over the 4 axes of |c - c_coarse|",
        "samples_max": int(max(c.samples for c in convs)),
        "quadrature": "MIS: GL x trapezoid hemisphere + GL x midpoint lobe; with --tol nested "
                      "Clenshaw-Curtis x trapezoid (tabulate.py)",
        "max_albedo": max_albedo,
        "energy_conserving": conserving,
    }
    if record_time:
        table_attrs["bake_seconds"] = float(sum(c.seconds for c in convs))
    datasets = {"/table": data.astype(np.float32), "/error": err_map.astype(np.float32)}
    dattrs = {
        "/table": table_attrs,
        "/error": {"meaning": "per-texel error estimate (same definition as /table)"},
    }
    for name, values in vary:
        datasets[f"/axes/{name}"] = np.asarray(values, dtype=np.float64)
    desc = brdf.describe()
    attrs = {
        "brdf_model": desc["model"],
        "brdf_parameters": desc["parameters"],
        "brdf_citation": brdf.spec.citation,
        "brdf_source": desc["source"],
        "brdf_coloured": coloured,
    }
    attrs |= file_source(brdf.source, brdf.source_sha256) if brdf.source else no_source()
    return Asset("brdf_table", attrs, datasets, dattrs)


def _view_z_min() -> float:
    from shbake.texture.parabolic import VIEW_Z_MIN  # numba: loaded only when a table is built

    return VIEW_Z_MIN


FIXED_AXES = ("channel", "row", "col", "coeff")


def _table_axes(dattrs) -> list:
    axes = (dattrs.get("/table") or {}).get("axes")
    if isinstance(axes, str):
        try:
            axes = json.loads(axes)
        except ValueError:
            return []
    return list(axes) if isinstance(axes, list | tuple) else []


def _members(spec, attrs, dattrs):
    return [f"/axes/{a}" for a in _table_axes(dattrs)
            if isinstance(a, str) and a not in FIXED_AXES]  # fmt: skip


def _check(attrs, shapes, dattrs, symbols):
    axes = dattrs["/table"]["axes"]
    table = shapes["/table"]
    if not all(isinstance(a, str) for a in axes) or list(axes[-3:]) != ["row", "col", "coeff"]:
        raise FormatError(f"/table attribute axes must name the axes and end with row, col, "
                          f"coeff; found {axes!r:.80}")  # fmt: skip
    if len(axes) != len(table):
        raise FormatError(f"/table has {len(table)} axes but its axes attribute names {len(axes)}")
    coloured = attrs["brdf_coloured"]
    if coloured != (axes[0] == "channel") or (coloured and table[0] != 3):
        raise FormatError("/table: a leading channel axis of 3 MUST be present exactly when "
                          "brdf_coloured is 1")  # fmt: skip
    vary = [a for a in axes if a not in FIXED_AXES]
    lead = table[1 if coloured else 0 : -3]
    if shapes["/error"] != tuple(lead) + tuple(table[-3:-1]):
        raise FormatError(f"dataset /error must have shape {tuple(lead) + tuple(table[-3:-1])}, "
                          f"found {shapes['/error']}")  # fmt: skip
    for name, n in zip(vary, lead, strict=True):
        if shapes.get(f"/axes/{name}") != (n,):
            raise FormatError(f"dataset /axes/{name} must have shape ({n},)")


BRDF_TABLE = register(Kind(
    name="brdf_table",
    version=2,
    title="SH of the BRDF product per view direction (Kautz et al. 2002; `brdf-table`)",
    attrs=(
        Attr("brdf_model", "str", "model name (`shbake brdf-table --help`)"),
        Attr("brdf_parameters", "json", "name → number or [r, g, b]; the values of varied "
             "parameters are those of the first axis point", json_type=dict),
        Attr("brdf_citation", "str", "where the model is defined"),
        Attr("brdf_source", "str", "MERL file as given, or `\"\"`", required=False),
        Attr("brdf_coloured", "bool", "RGB BRDF (a leading channel axis of 3 in `/table`)"),
    ),
    datasets=(
        Data("/table", ("*lead", "H", "W", "(lmax+1)**2"), "float32",
             "`c_i(v)` of `f*(s,v) = f(s,v) max(0,s_z)` per parabolic texel; axes "
             "`([channel,] *parameters, row, col, coeff)`",
             attrs=(
                 Attr("axes", "json", "names of every axis: `channel`, parameter names, "
                      "`row`, `col`, `coeff`", json_type=list),
                 Attr("lmax", "int", "highest band", range=(0, KAUTZ_LMAX_LIMIT), symbol="lmax"),
                 Attr("parameterisation", "str", "parabolic map, rows `p_y`, cols `p_x`, "
                      "texel centres; outside-disc texels hold the horizon value"),
                 Attr("view_z_min", "float", "smallest tabulated view `z`"),
                 Attr("error_estimate", "float", "max of `/error`"),
                 Attr("error_definition", "str", "what `/error` measures"),
                 Attr("samples_max", "int", "largest quadrature sample count", range=(1, 1 << 40)),
                 Attr("quadrature", "str", "integration rule"),
                 Attr("max_albedo", "floats", "largest white-furnace albedo per channel",
                      length=3),
                 Attr("energy_conserving", "bool", "max albedo ≤ 1 + 1e-3"),
                 Attr("bake_seconds", "float", "the only run-dependent value: writers MUST omit "
                      "it when asked for reproducible output (`--reproducible`)", required=False),
             )),
        Data("/error", ("*elead", "H", "W"), "float32",
             "per-texel quadrature error estimate, axes `(*parameters, row, col)`",
             attrs=(MEANING_ATTR,)),
        Data("/axes/{name}", ("N",), "float64",
             "the values of varied parameter `name` (one per parameter axis of `/table`)"),
    ),
    notes=("Consumers shade with `Q = Σ_i L_i c_i(v)` where `L` is the lighting rotated into "
           "the local frame (`docs/CONVENTIONS.md`).",),
    members=_members,
    check=_check,
))  # fmt: skip


def _json_attr(v):
    return json.loads(v) if isinstance(v, str) else v


@dataclass
class BRDFTable:
    """One parameter point of a ``brdf_table`` asset: ``coeffs (H, W, n, 3)``, BRDF record."""

    coeffs: np.ndarray
    lmax: int
    model: str
    params: dict
    source: str
    attrs: dict

    def make_brdf(self, merl_path: str | None = None, merl_sha256: str | None = None) -> "BRDF":
        """The tabulated BRDF, rebuilt from the recorded model and parameters; a measured
        (``merl``) one from ``merl_path``, the MERL file the user gave, whose bytes must hash
        to ``merl_sha256`` when given: the path the asset records (``source``) is never
        followed (docs/SECURITY.md §3)."""
        from shbake.brdf.model import make_brdf

        if self.model == "merl":
            return make_brdf("merl", merl_path, merl_sha256, **self.params)
        return make_brdf(self.model, **self.params)


def table_at(asset: Asset, at: dict | None = None) -> BRDFTable:
    """Select one parameter point of a table asset (nearest tabulated value per axis).

    ``at`` maps varied parameter names to values; unnamed axes take their first value.
    """
    if asset.kind != "brdf_table":
        raise FormatError(f"expected a brdf_table asset, got {asset.kind!r}")
    at = dict(at or {})
    data = np.asarray(asset["/table"], dtype=np.float64)
    tattrs = asset.dataset_attrs["/table"]
    axes = _json_attr(tattrs["axes"])
    if axes[0] == "channel":
        data = np.moveaxis(data, 0, -1)
    else:
        data = np.repeat(data[..., None], 3, axis=-1)
    params = _json_attr(asset.attrs["brdf_parameters"])
    vary_names = [a for a in axes if a not in ("channel", "row", "col", "coeff")]
    unknown = set(at) - set(vary_names)
    if unknown:
        raise ParameterError(
            f"{', '.join(sorted(unknown))}: not a varied axis of this table "
            f"(axes: {', '.join(vary_names) or 'none'})"
        )
    for name in vary_names:
        values = asset[f"/axes/{name}"]
        k = int(np.argmin(np.abs(values - float(at.get(name, values[0])))))
        data = data[k]
        params[name] = float(values[k])
    model = asset.attrs["brdf_model"]
    from shbake.brdf.model import model_spec  # numba: loaded only when a table is used

    model_spec(model)
    return BRDFTable(
        np.ascontiguousarray(data),
        lmax_of(data.shape[-2]),
        model,
        params,
        asset.attrs.get("brdf_source", ""),
        tattrs,
    )
