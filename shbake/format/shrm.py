"""The ``shrm`` asset (``docs/FORMAT.md`` § shrm): schema, builder and typed reader.

Datasets
    ``/shrm`` float32 ``(6, S, S, n, 3)``: the SHRM on a cube map (faces +X, −X,
    +Y, −Y, +Z, −Z of OpenEXR ``envmap = cube``, texel cells, rows top → bottom),
    ``n = (P+1)²`` global coefficients ``B̃_ps`` at index ``p(p+1)+s``
    (``surface``/``lobe`` kinds, indexed by the reflection vector), or
    ``n = P+1`` coefficients ``B_p0`` (``tangent`` kind, indexed by the tangent).
    ``/brdf_coefficients`` float64 ``(F+1, P+1, P+1, 3)``: ``ρ̂[l, p, |q|, c]``.
    ``/lighting/sh`` float64 ``((F+1)², 3)``: the map's ``L_lm`` used.
Root attributes
    ``brdf_model``, ``brdf_kind``, ``brdf_parameters`` (JSON), ``brdf_source`` (and
    for measured data ``brdf_source_sha256``), ``F``, ``P``, ``eps``, ``eps_brdf`` (BRDF
    energy left out), ``eps_bound`` (appendix B bound, worst channel), ``residual`` (JSON
    per channel), ``face_size``, ``layout``, ``coefficients`` (``global`` or
    ``tangent_q0``), ``view_convention``, ``method`` and the map's provenance
    ``source_*`` (the common block, FORMAT §2).

Timings vary between runs, so the CLI reports them and the asset does not
store them: same inputs give identical bytes.
"""

from dataclasses import dataclass

import numpy as np

from shbake.conventions import LMAX_LIMIT, lmax_of
from shbake.errors import FormatError
from shbake.format.asset import Asset, read_asset, write_asset
from shbake.format.provenance import map_source
from shbake.format.registry import MAP_KIND_ATTRS, Attr, Data, Kind, register

KIND = "shrm"
LAYOUT = "cube (6, S, S, n, 3): faces +X,-X,+Y,-Y,+Z,-Z as OpenEXR envmap=cube, texel cells"
VIEW_CONVENTION = (
    "V: unit world vector from the surface toward the viewer; R = 2(n.V)n - V; "
    "radiance(R, V) = sum_ps shrm[R, p(p+1)+s] y_ps(V) (eq. 7/12); tangent kind: "
    "sum_p shrm[T, p] y_p0(T.V)"
)


def _check(attrs, shapes, dattrs, symbols):
    n = shapes["/shrm"][3]
    P = attrs["P"]
    want = P + 1 if attrs["coefficients"] == "tangent_q0" else (P + 1) ** 2
    if n != want:
        raise FormatError(f"dataset /shrm has {n} coefficients per texel; P = {P} and "
                          f"coefficients {attrs['coefficients']!r} need {want}")  # fmt: skip


SHRM_KIND = register(Kind(
    name=KIND,
    version=2,
    title="Spherical Harmonic Reflection Map (Ramamoorthi & Hanrahan 2002; `shrm`)",
    attrs=MAP_KIND_ATTRS + (
        Attr("brdf_model", "str", "the BRDF (shbake model name or a reflection model)"),
        Attr("brdf_kind", "str", "`surface`, `lobe` (radially symmetric) or `tangent`"),
        Attr("brdf_parameters", "json", "the model's parameters", json_type=dict),
        Attr("brdf_source", "str", "measured data file, `\"\"` for analytic models"),
        Attr("brdf_source_sha256", "str", "hex SHA-256 of the measured data file, which "
             "`preview --merl` must match; absent for analytic models (and in files written "
             "before it)", required=False),
        Attr("F", "int", "lighting × BRDF order (highest band l)", range=(0, LMAX_LIMIT),
             symbol="F"),
        Attr("P", "int", "view order (highest band p)", range=(0, LMAX_LIMIT), symbol="P"),
        Attr("eps", "float", "energy tolerance ε the orders were chosen for", range=(0.0, 1.0)),
        Attr("eps_brdf", "float", "BRDF energy left out at (F, P)", range=(0.0, 1.0)),
        Attr("eps_reached", "bool", "whether ε was met within the order limits"),
        Attr("eps_bound", "float", "appendix-B residual bound, worst channel"),
        Attr("residual", "json", "appendix-B bound per channel", json_type=dict),
        Attr("face_size", "int", "cube face texels `S`", range=(1, 4096), symbol="S"),
        Attr("layout", "str", "the cube layout"),
        Attr("coefficients", "str", "`global` ((P+1)² per texel) or `tangent_q0` (P+1)"),
        Attr("view_convention", "str", "how a renderer evaluates a texel for a view (eq. 7/12)"),
        Attr("method", "str", "the prefiltering method"),
    ),
    datasets=(
        Data("/shrm", (6, "S", "S", "n", 3), "float32",
             "the SHRM on a cube (faces +X, −X, +Y, −Y, +Z, −Z, OpenEXR `envmap = cube`)",
             attrs=(Attr("layout", "str", "the cube's layout", required=False),
                    Attr("index", "str", "how the last-but-one axis is indexed", required=False))),
        Data("/brdf_coefficients", ("F+1", "P+1", "P+1", 3), "float64",
             "`ρ̂[l, p, |q|, channel]` (real basis, RH02 eq. 13)",
             attrs=(Attr("index", "str", "the axes", required=False),
                    Attr("basis", "str", "the SH basis", required=False))),
        Data("/lighting/sh", ("(F+1)**2", 3), "float64", "the map's `L_lm` used",
             attrs=(Attr("lmax", "int", "highest band (`F`)", range=(0, LMAX_LIMIT),
                         required=False),)),
    ),
    check=_check,
))  # fmt: skip


def build_shrm_asset(bake, env_meta: dict) -> Asset:
    """The ``shrm`` asset of a :class:`~shbake.bakers.shrm.ShrmBake` and the map's metadata."""
    rb = bake.brdf
    attrs = {
        "brdf_model": rb.name,
        "brdf_kind": rb.kind,
        "brdf_parameters": rb.describe()["parameters"],
        "brdf_source": rb.source,
        "F": np.int64(bake.F),
        "P": np.int64(bake.P),
        "eps": float(bake.orders.eps_target),
        "eps_brdf": float(bake.orders.eps_brdf),
        "eps_reached": bool(bake.orders.reached),
        "eps_bound": float(bake.bound["eps_bound_max"]),
        "residual": bake.bound,
        "face_size": np.int64(bake.face_size),
        "layout": LAYOUT,
        "coefficients": "tangent_q0" if rb.kind == "tangent" else "global",
        "view_convention": VIEW_CONVENTION,
        "method": "Ramamoorthi & Hanrahan 2002, frequency-space prefiltering (appendix C)",
    }
    if rb.source:  # analytic SHRMs keep their bytes
        attrs["brdf_source_sha256"] = rb.source_sha256
    attrs.update(map_source(env_meta))
    datasets = {
        "/shrm": np.ascontiguousarray(bake.cube, dtype=np.float32),
        "/brdf_coefficients": np.ascontiguousarray(bake.coeffs.rho, dtype=np.float64),
        "/lighting/sh": np.ascontiguousarray(bake.light, dtype=np.float64),
    }
    dattrs = {
        "/shrm": {"layout": LAYOUT, "index": "p*(p+1)+s" if rb.kind != "tangent" else "p"},
        "/brdf_coefficients": {"index": "[l, p, |q|, channel]", "basis": "real, RH02 eq. 13"},
        "/lighting/sh": {"lmax": int(bake.F)},
    }
    return Asset(KIND, attrs, datasets, dattrs)


def write_shrm(path: str, asset: Asset) -> None:
    """Write an ``shrm`` asset atomically and deterministically."""
    if asset.kind != KIND:
        raise FormatError(f"not an shrm asset: {asset.kind!r}")
    write_asset(path, asset)


@dataclass
class SHRM:
    """An ``shrm`` asset read back: the arrays and the numbers a shader needs."""

    cube: np.ndarray
    kind: str
    F: int
    P: int
    face_size: int
    attrs: dict

    @property
    def shading_kind(self) -> str:
        return "tangent" if self.kind == "tangent" else "surface"


def shrm_from_asset(asset: Asset) -> SHRM:
    """Typed view of an ``shrm`` :class:`~shbake.format.asset.Asset` (checks the shape)."""
    if asset.kind != KIND:
        raise FormatError(f"asset kind {asset.kind!r} is not shrm")
    cube = asset["/shrm"]
    a = asset.attrs
    F, P, S = int(a["F"]), int(a["P"]), int(a["face_size"])
    kind = a["brdf_kind"]
    n = P + 1 if kind == "tangent" else (P + 1) ** 2
    if cube.shape != (6, S, S, n, 3):
        raise FormatError(f"/shrm has shape {cube.shape}, expected {(6, S, S, n, 3)}")
    return SHRM(cube, kind, F, P, S, a)


def read_shrm(path: str) -> SHRM:
    """Read an ``shrm`` asset file."""
    return shrm_from_asset(read_asset(path, kinds=(KIND,)))


def write_exr_cubes(directory: str, cube: np.ndarray, tangent: bool,
                    reflection: np.ndarray, png: bool = False) -> list[str]:  # fmt: skip
    """``shrm_p{p}.exr`` per ``p`` of the SHRM ``cube (6, S, S, n, 3)`` (channels
    ``q{q}.R/G/B``; ``tangent`` kind: ``R/G/B`` of ``B_p0``) and ``reflection.exr`` (the
    eq. 12 cube ``(6, S, S, 3)`` the caller shaded for one view), OpenEXR cube strips
    (float32); with ``png`` a PNG beside each: the ``q`` components (channel mean) side by
    side, and the reflection tone-mapped. The paths written."""
    import os

    from shbake.format.atomic import makedirs
    from shbake.format.images import component_strip, tonemap_to_srgb8, write_exr, write_png

    makedirs(directory)
    S = cube.shape[1]
    P = cube.shape[3] - 1 if tangent else lmax_of(cube.shape[3])
    written = []
    for p in range(P + 1):
        if tangent:
            img = cube[:, :, :, p, :]
            names = ("R", "G", "B")
        else:
            img = cube[:, :, :, p * p : (p + 1) ** 2, :].reshape(6, S, S, -1)
            names = tuple(f"q{q}.{c}" for q in range(-p, p + 1) for c in "RGB")
        path = os.path.join(directory, f"shrm_p{p}.exr")
        write_exr(path, img.reshape(6 * S, S, -1), half=False, attrs={"envmap": "cube"},
                  channel_names=names)  # fmt: skip
        written.append(path)
        if png:
            written.append(os.path.join(directory, f"shrm_p{p}.png"))
            write_png(written[-1], component_strip(img.reshape(6 * S, S, -1, 3).mean(axis=-1)))
    path = os.path.join(directory, "reflection.exr")
    write_exr(path, reflection.reshape(6 * S, S, 3), half=False, attrs={"envmap": "cube"})
    written.append(path)
    if png:
        written.append(os.path.join(directory, "reflection.png"))
        write_png(written[-1], tonemap_to_srgb8(reflection.reshape(6 * S, S, 3)))
    return written
