"""WebGL2 export: the textures and uniforms shbake's GLSL shaders read, the shaders, a viewer.

``shbake export ASSET --to webgl -o DIR`` writes the folder ``DIR`` (``docs/SHADERS.md``),
staged beside it and put in place whole when the run commits: a folder of an earlier
export there is replaced, never merged into (:func:`check_replaceable`; any other
existing folder is refused):

* ``shbake.json``: the manifest — the asset's name and kind, the passes it can draw,
  the GLSL files in include order, each texture (file, width, height, layers) and
  each uniform (GLSL type, value), and the asset's parameters for display;
* one ``NAME.ktx2`` per texture: KTX 2.0, ``VK_FORMAT_R32G32B32A32_SFLOAT`` (float32
  RGBA), one level, no supercompression, 2D or a 2D array (``layerCount`` the layers)
  (:func:`shbake.format.exports.ktx2.write_ktx2`); row 0 first:
  ``texelFetch(tex, ivec2(column, row))`` reads the stored array ``[row, column]``;
* the GLSL files of :mod:`shbake.shaders` the passes need and the loader
  ``shbake_webgl.mjs``;
* ``index.html`` (+ ``viewer.mjs``, ``viewer.css``): the sphere with orbit controls and
  the asset's parameters. Served over HTTP (browsers refuse ``fetch`` from ``file:``
  pages), e.g. ``python3 -m http.server -d DIR``.

The export is in shbake's world frame (+Y up): ``--frame``/``--rotate`` are refused.
The only string from the asset that reaches the page is its file name, in the
autoescaped ``<title>``; the manifest's strings reach the page as text nodes
(``textContent``) only.
"""

import json
import math
import os
import re
import stat
from importlib import resources

import numpy as np

from shbake.conventions import to_float32
from shbake.errors import InputError, OutputError
from shbake.format.atomic import atomic_folder, atomic_path, makedirs, transaction, write_text
from shbake.format.exports.ktx2 import EXTENSION as KTX2
from shbake.format.exports.ktx2 import write_ktx2
from shbake.resources import same_input

CUBES = None
"""No cube maps."""
EXTENSION = ""
OUTPUT_ENDINGS = None
"""The export is a folder (named after the asset with ``--out-dir``)."""
MAX_LIGHTS = 8
"""``SHBAKE_MAX_LIGHTS`` of common.glsl: the sun or up to 8 fitted lights
(:data:`shbake.bakers.env_lights.MAX_LIGHTS`)."""
MAX_KNOTS = 8
"""SH-exp coefficient sets the shader's uniform arrays hold (``probe-fit --sets`` ≤ 8)."""
KAUTZ_LMAX = 8
"""Largest table lmax of kautz.glsl (``SHBAKE_KAUTZ_LMAX``: its per-pixel rotation blocks)."""
MAX_LEVELS = 16
"""Split-sum levels the shader's uniform arrays hold (:data:`shbake.format.splitsum.LEVELS_MAX`)."""
COEFF_ROW = 1024
"""Texels per row of a coefficient texture (element ``k`` at ``(k mod 1024, k div 1024)``):
lmax 128 irradiance takes 17 rows, well inside WebGL2's 2048-texel minimum."""
VIEWER_FILES = ("shbake_webgl.mjs", "viewer.mjs", "viewer.css")
SHADERS = {
    "env_sh": ("common.glsl", "irradiance.glsl", "tangent_irradiance.glsl"),
    "splitsum_probe": ("common.glsl", "dfg.glsl", "splitsum.glsl"),
    "shexp_probe": ("common.glsl", "dfg.glsl", "shexp.glsl"),
    "shexp_probe_set": ("common.glsl", "dfg.glsl", "shexp.glsl"),
    "shrm": ("common.glsl", "shrm.glsl"),
    "brdf_table": ("common.glsl", "kautz.glsl"),
}
"""The GLSL files of each asset kind, in include order."""


def _rgba(a: np.ndarray) -> np.ndarray:
    """``(..., C)`` → ``(..., 4)`` float64, channels past ``C`` zero (stored as float32 by
    :func:`build_export`)."""
    a = np.asarray(a, dtype=np.float64)
    out = np.zeros(a.shape[:-1] + (4,))
    out[..., : a.shape[-1]] = a
    return out


def coefficient_texture(coeffs: np.ndarray) -> np.ndarray:
    """SH coefficients ``(n, 3)``, or sets of them ``(S, n, 3)``, → texels
    ``(rows, width, 4)``: the sets one after the other, element ``k = s·n + i``
    (coefficient ``i`` of set ``s``) at ``(k mod width, k div width)``,
    ``width = min(S·n, max(COEFF_ROW, ⌈√(S·n)⌉))`` (square when large), zero-padded
    (common.glsl, ``shbakeCoeff``)."""
    flat = np.asarray(coeffs, dtype=np.float64).reshape(-1, np.shape(coeffs)[-1])
    width = min(flat.shape[0], max(COEFF_ROW, math.isqrt(flat.shape[0] - 1) + 1))
    rows = -(-flat.shape[0] // width)
    out = np.zeros((rows * width, 4))
    out[: flat.shape[0]] = _rgba(flat)
    return out.reshape(rows, width, 4)


def _lights(lights) -> dict:
    dirs, energy, radii = lights
    if len(dirs) > MAX_LIGHTS:
        raise InputError(f"--to webgl draws at most {MAX_LIGHTS} lights (SHBAKE_MAX_LIGHTS); "
                         f"the asset has {len(dirs)}")  # fmt: skip
    d = np.zeros((MAX_LIGHTS, 3))
    e = np.zeros((MAX_LIGHTS, 3))
    r = np.zeros(MAX_LIGHTS)
    d[: len(dirs)], e[: len(dirs)], r[: len(dirs)] = dirs, energy, radii
    return {
        "uLightDir": {"type": "vec3[]", "length": MAX_LIGHTS, "value": d.tolist()},
        "uLightE": {"type": "vec3[]", "length": MAX_LIGHTS, "value": e.tolist()},
        "uLightCount": {"type": "int", "value": len(dirs)},
        "uLightRadius": {"type": "float[]", "length": MAX_LIGHTS, "value": r.tolist()},
    }


def _env_sh(asset, lights):
    """``context``: the asset's lights (:func:`shbake.shading.env_sh.lights_of`)."""
    textures, uniforms, passes = {}, _lights(lights), []
    for key, tex, lmax_name, passname in (
        ("/irradiance/sh", "uIrradiance", "uIrradianceLmax", "irradiance"),
        ("/tangent_irradiance/sh", "uTangentSH", "uTangentLmax", "tangent-sh"),
    ):
        if key in asset:
            c = np.asarray(asset[key], dtype=np.float64)
            textures[tex] = coefficient_texture(c)
            uniforms[lmax_name] = {"type": "int", "value": int(round(np.sqrt(c.shape[0]))) - 1}
            passes.append(passname)
    if "/tangent_irradiance/matrix" in asset:
        m = np.asarray(asset["/tangent_irradiance/matrix"], dtype=np.float64)
        # column-major mat4 per channel (uniformMatrix4fv, transpose false): M^T row-major
        uniforms["uTangentM"] = {"type": "mat4[]", "length": 3,
                                 "value": [mc.T.tolist() for mc in m]}  # fmt: skip
        passes.append("tangent-matrix")
    if not passes:
        raise InputError("the env_sh asset has no irradiance to draw")
    params = {"lights": int(uniforms["uLightCount"]["value"])}
    for k in ("lmax", "lmax_irradiance"):
        if k in asset.attrs:
            params[k] = int(asset.attrs[k])
    return textures, uniforms, passes, params


def _dfg(asset) -> np.ndarray:
    """``/dfg`` ``(n_μ, n_r, 2)`` → one layer, rows ``n·v``, columns ``sqrt(α)``."""
    return _rgba(asset["/dfg"])[None]


def _splitsum(asset, _lights):
    n = int(asset.attrs["levels"])
    if n > MAX_LEVELS:
        raise InputError(f"the split-sum probe has {n} levels; the shader holds {MAX_LEVELS}")
    levels = [np.asarray(asset[f"/levels/{k}"]) for k in range(n)]
    top = max(lv.shape[0] for lv in levels)
    layers = np.zeros((n, top, top, 4))
    for k, lv in enumerate(levels):
        layers[k, : lv.shape[0], : lv.shape[1]] = _rgba(lv)
    alphas = np.asarray(asset["/level_alpha"], dtype=np.float64)
    pad = MAX_LEVELS - n
    uniforms = {
        "uLevelSize": {"type": "int[]", "length": MAX_LEVELS,
                       "value": [lv.shape[0] for lv in levels] + [0] * pad},
        "uLevelAlpha": {"type": "float[]", "length": MAX_LEVELS,
                        "value": alphas.tolist() + [0.0] * pad},
        "uLevelCount": {"type": "int", "value": n},
    }  # fmt: skip
    params = {"levels": n, "alpha_range": [float(alphas[0]), float(alphas[-1])]}
    return {"uLevels": layers, "uDFG": _dfg(asset)}, uniforms, ["splitsum"], params


def _shexp(asset, _lights):
    """``/p`` and ``/q`` (with their DC coefficient, zero) as coefficient textures, probe
    ``j``'s set ``k`` the texture's set ``j K + k``; a ``shexp_probe`` is one probe, a set's
    probe 0 is drawn (``uProbe`` picks another)."""
    p = np.asarray(asset["/p"], dtype=np.float64)
    q = np.asarray(asset["/q"], dtype=np.float64)
    if asset.kind == "shexp_probe":
        p, q = p[None], q[None]
    knots = np.asarray(asset["/knots"], dtype=np.float64)
    q = np.concatenate([np.zeros(q.shape[:2] + (1, 3)), q], axis=2)  # the DC, zero
    n_probes, k = p.shape[0], p.shape[1]
    if k > MAX_KNOTS:
        raise InputError(f"the probe has {k} coefficient sets; the shader holds {MAX_KNOTS}")
    pad = MAX_KNOTS - k
    uniforms = {
        "uLmaxP": {"type": "int", "value": int(round(np.sqrt(p.shape[2]))) - 1},
        "uLmaxQ": {"type": "int", "value": int(round(np.sqrt(q.shape[2]))) - 1},
        "uKnots": {"type": "float[]", "length": MAX_KNOTS,
                   "value": knots.tolist() + [0.0] * pad},
        "uKnotCount": {"type": "int", "value": k},
        "uProbe": {"type": "int", "value": 0},
    }  # fmt: skip
    textures = {
        "uP": coefficient_texture(p.reshape(n_probes * k, -1, 3)),
        "uQ": coefficient_texture(q.reshape(n_probes * k, -1, 3)),
        "uDFG": _dfg(asset),
    }
    params = {"probes": n_probes, "sets": k, "alpha_range": [float(knots[0]), float(knots[-1])]}
    params.update(lmax_p=uniforms["uLmaxP"]["value"], lmax_q=uniforms["uLmaxQ"]["value"])
    return textures, uniforms, ["shexp"], params


def _shrm(asset, _lights):
    """``/shrm`` ``(6, S, S, n, 3)`` as a coefficient texture, texel ``(f, i, j)`` the set
    ``(f S + i) S + j``; the tangent kind's ``B_p0`` at index ``p(p+1)`` of a full set."""
    from shbake.conventions import CUBE_FACES

    cube = np.asarray(asset["/shrm"], dtype=np.float64)
    size, n = cube.shape[1], cube.shape[3]
    tangent = asset.attrs["brdf_kind"] == "tangent"
    P = n - 1 if tangent else int(round(np.sqrt(n))) - 1
    if tangent:
        full = np.zeros(cube.shape[:3] + ((P + 1) ** 2, 3))
        full[..., [p * (p + 1) for p in range(P + 1)], :] = cube
        cube = full
    faces = [np.asarray(a, dtype=np.float64).T.tolist() for _, a in CUBE_FACES]  # columns of A
    uniforms = {
        "uShrmP": {"type": "int", "value": P},
        "uShrmSize": {"type": "int", "value": size},
        "uShrmTangent": {"type": "int", "value": int(tangent)},
        "uCubeFaces": {"type": "mat3[]", "length": 6, "value": faces},
    }
    params = {"brdf": str(asset.attrs["brdf_model"]), "brdf_kind": str(asset.attrs["brdf_kind"]),
              "P": P, "face_size": size}  # fmt: skip
    return (
        {"uShrm": coefficient_texture(cube.reshape(-1, cube.shape[3], 3))},
        uniforms,
        ["shrm"],
        params,
    )


def _kautz(asset, context):
    """``context``: ``(BRDFTable, L)``: the table's parameter point
    (:func:`shbake.format.brdf_table.table_at`) and the world lighting that shades it,
    ``((lmax+1)², 3)`` (:func:`shbake.shading.brdf_table.lighting_with_sun`)."""
    table, lighting = context
    h, w, n = table.coeffs.shape[:3]
    if table.lmax > KAUTZ_LMAX:
        raise InputError(f"the table has lmax {table.lmax}; the kautz shader holds {KAUTZ_LMAX}")
    uniforms = {
        "uKautzLmax": {"type": "int", "value": table.lmax},
        "uKautzH": {"type": "int", "value": h},
        "uKautzW": {"type": "int", "value": w},
    }
    textures = {
        "uKautzTable": coefficient_texture(table.coeffs.reshape(h * w, n, 3)),
        "uKautzL": coefficient_texture(lighting),
    }
    params = {"brdf": table.model, "brdf_parameters": table.params, "lmax": table.lmax,
              "table": [h, w]}  # fmt: skip
    return textures, uniforms, ["kautz", "kautz-fixed-light", "kautz-fixed-view"], params


TEXTURES_OF_KIND = {
    "env_sh": _env_sh,
    "splitsum_probe": _splitsum,
    "shexp_probe": _shexp,
    "shexp_probe_set": _shexp,
    "shrm": _shrm,
    "brdf_table": _kautz,
}
"""Asset kind → ``(textures, uniforms, passes, parameters)`` of its export."""


def _texture_entry(name: str, texels: np.ndarray) -> dict:
    layered = texels.ndim == 4
    h, w = texels.shape[-3], texels.shape[-2]
    entry = {"file": name + KTX2, "width": int(w), "height": int(h)}
    if layered:
        entry["layers"] = int(texels.shape[0])
    return entry


def _copy_package_file(name: str, dest: str) -> None:
    data = resources.files("shbake.shaders").joinpath(name).read_bytes()
    with atomic_path(dest) as tmp, open(tmp, "wb") as f:
        f.write(data)


MANIFEST = "shbake.json"
MANIFEST_BYTES = 1 << 20
"""Largest manifest :func:`check_replaceable` reads (an export's is a few KiB)."""
TEXTURE_FILE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*\.ktx2$")


def check_replaceable(out: str) -> None:
    """Refuse to replace ``out`` unless it is missing, an empty folder, or a folder of an
    earlier export: regular files only, each named as an export names its files (textures
    ``NAME.ktx2``, the package's GLSL and viewer files, ``index.html``, :data:`MANIFEST`),
    and a manifest of format ``shbake-webgl``. A user's other folder is never removed."""
    if not os.path.lexists(out):
        return
    if os.path.islink(out) or not os.path.isdir(out):
        raise OutputError(f"{out}: exists and is not a folder (-o names the export's folder)")
    known = {MANIFEST, "index.html", *VIEWER_FILES, *(f for fs in SHADERS.values() for f in fs)}
    names = os.listdir(out)
    for name in names:
        src = same_input(os.path.join(out, name))
        if src is not None:  # replacing the folder would remove an input of this run
            raise OutputError(f"{out}: holds the input {src}; not replaced (choose another "
                              "folder)")  # fmt: skip
        mode = os.lstat(os.path.join(out, name)).st_mode
        if not (stat.S_ISREG(mode) and (name in known or TEXTURE_FILE.match(name))):
            raise OutputError(f"{out}: holds {name!r}, not a file of a webgl export; "
                              "not replaced (name a new or an export's folder)")  # fmt: skip
    if not names:
        return
    try:
        with open(os.path.join(out, MANIFEST), "rb") as f:
            data = f.read(MANIFEST_BYTES + 1)
        manifest = json.loads(data) if len(data) <= MANIFEST_BYTES else None
        ok = isinstance(manifest, dict) and manifest.get("format") == "shbake-webgl"
    except (OSError, ValueError):
        ok = False
    if not ok:
        raise OutputError(f"{out}: has no {MANIFEST} of a webgl export; not replaced "
                          "(name a new or an export's folder)")  # fmt: skip


def viewer_page(title: str) -> str:
    """``index.html`` from the autoescaped template ``shaders/viewer.html``."""
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("shbake", "shaders"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
    )
    return env.get_template("viewer.html").render(title=title)


def build_export(asset, name: str, context=None, source: str | None = None
                 ) -> tuple[dict, dict]:  # fmt: skip
    """The export of ``asset`` (a kind of :data:`TEXTURES_OF_KIND`, read from the file
    ``name``) without writing anything: ``(manifest, {texture name: float32 texels})``. Every
    check of its kind runs here (at most :data:`MAX_LIGHTS` lights, a table's lmax, the levels
    and coefficient sets the shaders hold, texels float32 holds —
    :func:`shbake.conventions.to_float32`: an :class:`~shbake.errors.InputError` naming
    ``source``, the file as given, default ``name``).
    ``context``: what the kind's pass reads from elsewhere — an ``env_sh`` asset's lights
    ``(directions (K, 3), E (K, 3), radii (K,))`` (:func:`shbake.shading.env_sh.lights_of`),
    a ``brdf_table``'s ``(BRDFTable, L)``."""
    try:
        textures, uniforms, passes, params = TEXTURES_OF_KIND[asset.kind](asset, context)
    except InputError as e:
        raise InputError(f"{source or name}: {e}") from None
    textures = {k: to_float32(t, source or name, f"the webgl texture {k}")
                for k, t in textures.items()}  # fmt: skip
    manifest = {
        "format": "shbake-webgl",
        "version": 2,
        "asset": {"name": name, "kind": asset.kind, "parameters": params},
        "passes": passes,
        "shaders": list(SHADERS[asset.kind]),
        "textures": {k: _texture_entry(k, t) for k, t in textures.items()},
        "uniforms": uniforms,
    }
    return manifest, textures


def write_export(manifest: dict, textures: dict, out: str) -> list[str]:
    """Write an export (:func:`build_export`) as the folder ``out`` (replacing an earlier
    export there, :func:`check_replaceable`); the files written, as they are named once
    committed."""
    out = os.path.abspath(out)
    check_replaceable(out)
    shaders = tuple(manifest["shaders"])
    names = [k + KTX2 for k in textures] + [*shaders, *VIEWER_FILES, MANIFEST, "index.html"]
    asset = manifest["asset"]
    with transaction():
        makedirs(os.path.dirname(out))
        with atomic_folder(out) as folder:
            for k, t in textures.items():
                write_ktx2(os.path.join(folder, k + KTX2), [t], cube=False, type_size=4,
                           layered=t.ndim == 4)  # fmt: skip
            for f in shaders + VIEWER_FILES:
                _copy_package_file(f, os.path.join(folder, f))
            write_text(os.path.join(folder, MANIFEST),
                       json.dumps(manifest, indent=1, sort_keys=True) + "\n")  # fmt: skip
            write_text(os.path.join(folder, "index.html"),
                       viewer_page(f"{asset['name']} ({asset['kind']})"))  # fmt: skip
    return [os.path.join(out, n) for n in names]


__all__ = [
    "TEXTURES_OF_KIND",
    "build_export",
    "check_replaceable",
    "coefficient_texture",
    "viewer_page",
    "write_export",
]
