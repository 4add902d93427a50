"""Filament export: cmgen's ``sh.txt``, KTX1 IBL and skybox cube maps with the SH in their metadata.

Derived from Filament's own source (``docs/EXPORTS.md``) and rendered by Filament 1.53.4 in
a browser by ``tests/system/test_engine_render.py``:

* ``IndirectLight::Builder::irradiance(3, sh)`` and the shader's
  ``irradianceSH(n) = sh0 + sh1 y + sh2 z + sh3 x + sh4 yx + sh5 yz + sh6 (3z²−1)
  + sh7 zx + sh8 (x²−y²)`` take cmgen's ``--sh-shader`` coefficients:
  ``libs/ibl/src/CubemapSH.cpp`` ``computeSH(irradiance=true)`` projects on a
  Condon–Shortley basis (``computeShBasis``: ``Pmm = (1 − 2m) Pmm``) and folds
  in ``computeTruncatedCosSh`` (``π, 2π/3, π/4``); ``preprocessSHForShader``
  multiplies by the signed polynomial constants ``A[i]`` (negative for
  ``m = ±1``) and by ``1/π``. The two signs cancel, so
  ``sh_i = E_i |c_i| / π`` with shbake's ``E_i`` and ``c_i`` its basis constants
  (0.282095, 0.488603, 1.092548, 0.315392, 0.546274): ``irradianceSH(n) = E(n)/π``,
  the Lambert radiance at albedo 1 (Filament multiplies by the diffuse colour).
* Frame: cmgen's ``equirectangularToCubemap`` reads ``u = (atan2(x, z)/π + 1)/2``
  (+X at ``u = 0.75``, shbake has it at 0.25) and ``main`` then mirrors the cube
  (``mirrorCubemap``: ``dst(N) = src(−N.x, N.y, N.z)``, "we mirror by default"):
  the two x mirrors cancel and Filament's frame is shbake's (right-handed, +Y up).
* ``sh.txt``: ``outputSh`` lines ``(r, g, b); // Llm, irradiance, pre-scaled base``,
  fixed, 15 decimals, width 18. KTX1 metadata ``sh``: nine ``"r g b\\n"`` lines
  (``iblRoughnessPrefilter``: ``container.setMetadata("sh", …)``), read by
  ``Ktx1Bundle::getSphericalHarmonics``.
* Cube maps: KTX 1.1 as cmgen writes them (``tools/cmgen/src/cmgen.cpp``
  ``iblRoughnessPrefilter``/``exportKtxFaces``): ``R11F_G11F_B10F`` texels
  (``GL_UNSIGNED_INT_10F_11F_11F_REV`` packing, :func:`pack_r11g11b10`; ``glType`` and
  ``glInternalFormat`` ``0x8C3A``, ``glFormat`` RGB, read by ``libs/ktxreader``
  ``Ktx1Reader.cpp`` ``toPixelDataType``/``toPixelDataFormat``), one of the formats
  Filament's web ``createIblFromKtx1`` expects (``web/filament-js/utilities.js``; it warns
  for any other). Faces +X, −X, +Y, −Y, +Z, −Z, each a GL face **mirrored in x**
  (:func:`filament_faces`): Filament samples world ``d`` at GL ``d`` itself, where
  shbake's cubes (three.js's convention) hold world ``(−g_x, g_y, g_z)`` at GL ``g``.
  ``_ibl.ktx`` holds the GGX chain with Filament's roughness↔LOD mapping
  (``lod = (levels − 1) r(2 − r)``), by default 256² (cmgen's ``IBL_DEFAULT_SIZE``) to 4²
  faces (cmgen stops at ``IBL_DEFAULT_MIN_LOD_SIZE`` 16², where r 0.6 reads a level of
  another roughness; docs/EXPORTS.md); ``_skybox.ktx`` the mirror level.
* SH: ``createIblFromKtx1`` reads the ``sh`` metadata into ``ibl.shfloats`` and never
  gives it to the light (Filament 1.53.4 ``filament.js`` ``_createIblFromKtx1``), so the
  light's diffuse would come from the reflections' roughest level: ``docs/EXPORTS.md``'s
  snippet builds the light with ``irradianceSh(3, sh)``.
* Sun: ``<stem>_sun.json`` for a ``LightManager::Type::SUN``: ``direction`` is
  where the light travels (−toward-sun), ``intensity`` in lux = the largest
  channel of the sun's irradiance, ``color`` = irradiance / intensity.
  Fitted lights (``project-env --lights``): ``<stem>_lights.json``, a list of such
  entries of type ``DIRECTIONAL`` (brightest first).
"""

import json
import struct

import numpy as np

from shbake.errors import OutputError
from shbake.format.atomic import atomic_path, write_text
from shbake.format.exports.source import ExportSource, require_sh
from shbake.format.images import clamp_to_half
from shbake.sh.basis import real_sh

EXTENSION = "_sh.txt"
OUTPUT_ENDINGS = ("_sh.txt",)
KTX1_IDENTIFIER = bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x31, 0x31, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A])
GL_RGB, GL_R11F_G11F_B10F = 0x1907, 0x8C3A
R11G11B10_MAX = 64512.0
"""The largest value all three channels hold (a 10-bit float: exponent 30, mantissa 31/32)."""
_NAMES = ["L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22"]


def basis_constants() -> np.ndarray:
    """``|c_i|``: shbake's 9 basis functions divided by their polynomials, from ``real_sh``."""
    d = np.array([[0.6, 0.48, 0.64]])
    x, y, z = d[0]
    poly = np.array([1, y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y])
    return np.abs(real_sh(d, 2)[0] / poly)


def filament_sh(irradiance9: np.ndarray) -> np.ndarray:
    """cmgen ``--sh-shader`` coefficients (9×3) of shbake irradiance SH ``E_i``."""
    return np.asarray(irradiance9, dtype=np.float64) * (basis_constants() / np.pi)[:, None]


def sh_text(sh: np.ndarray) -> str:
    """``sh.txt`` as cmgen's ``outputSh`` writes it."""
    lines = []
    for i, (r, g, b) in enumerate(sh):
        lines.append(
            f"({r:18.15f}, {g:18.15f}, {b:18.15f}); // {_NAMES[i]}, irradiance, pre-scaled base"
        )
    return "\n".join(lines) + "\n"


def sh_metadata(sh: np.ndarray) -> str:
    """The KTX ``sh`` metadata value: nine ``r g b`` lines."""
    return "".join(f"{r:.9g} {g:.9g} {b:.9g}\n" for r, g, b in sh)


def pack_r11g11b10(rgb: np.ndarray) -> np.ndarray:
    """Non-negative ``(…, 3)`` floats ≤ :data:`R11G11B10_MAX` as ``uint32`` texels of
    ``GL_UNSIGNED_INT_10F_11F_11F_REV``: R in bits 0–10 and G in 11–21 (5-bit exponent,
    6-bit mantissa), B in 22–31 (5-bit mantissa), bias 15 — a half float with its mantissa
    rounded to 6 (5) bits (GL ES 3.0 §2.1.3–2.1.4)."""
    h = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, None).astype(np.float16)
    bits = h.view(np.uint16).astype(np.uint32)
    r = (bits[..., 0] + 0x8) >> 4
    g = (bits[..., 1] + 0x8) >> 4
    b = (bits[..., 2] + 0x10) >> 5
    return (r | (g << 11) | (b << 22)).astype("<u4")


def filament_faces(level: np.ndarray) -> np.ndarray:
    """A cube level ``(6, n, n, 3)`` in shbake's convention as Filament samples it: mirrored
    in x (±X faces swapped, every face's columns reversed: GL ``(s, t)`` on +X is
    ``(−s, t)`` on −X, and ``s`` runs along ±x or z on the others)."""
    return np.asarray(level)[[1, 0, 2, 3, 4, 5], :, ::-1]


def encode_ktx1(levels: list[np.ndarray], kv: dict) -> bytes:
    """KTX 1.1 bytes of an ``R11F_G11F_B10F`` cube map (cmgen's header); ``levels[i]`` is
    ``(6, n, n, 3)``, Filament's face orientation, values within :data:`R11G11B10_MAX`."""
    n0 = levels[0].shape[1]
    kvd = b""
    for k in sorted(kv):
        entry = k.encode() + b"\0" + kv[k].encode() + b"\0"
        kvd += struct.pack("<I", len(entry)) + entry + b"\0" * (-len(entry) % 4)
    out = KTX1_IDENTIFIER + struct.pack(
        "<13I",
        0x04030201,
        GL_R11F_G11F_B10F,  # glType: Filament's Ktx1Reader reads this value, as cmgen writes
        1,
        GL_RGB,
        GL_R11F_G11F_B10F,
        GL_RGB,
        n0,
        n0,
        0,
        0,
        6,
        len(levels),
        len(kvd),
    )
    out += kvd
    for lv in levels:
        a = np.asarray(lv, dtype=np.float64)
        if not np.all(np.isfinite(a)) or a.max() > R11G11B10_MAX:
            raise OutputError("KTX level has values that R11F_G11F_B10F cannot hold")
        faces = [pack_r11g11b10(a[f]).tobytes() for f in range(6)]
        out += struct.pack("<I", len(faces[0]))  # imageSize: one face (non-array cube map)
        out += b"".join(faces)  # 4-byte texels: no face or mip padding
    return out


MIN_ROUGHNESS = 0.089
"""Filament's floor on perceptual roughness in its mobile materials (the web build's;
``shaders/src/common_material.fs`` ``MIN_PERCEPTUAL_ROUGHNESS``): it never reads the chain
below ``lod = (n − 1) · 0.089 (2 − 0.089)`` (level 1 of seven), so the levels it reads only
blended are refitted to that blend (:mod:`shbake.bakers.lod_blend`)."""

CUBES = {"size": 256, "floor": 4, "samples": 512, "mapping": "filament",
         "min_roughness": MIN_ROUGHNESS}  # fmt: skip
"""The cube chain this target wants: 256² (cmgen's) to 4², Filament's roughness↔LOD mapping
and roughness floor (always)."""


def write(
    src: ExportSource,
    out: str,
    levels: list[np.ndarray] | None = None,
    roughness: list[float] | None = None,
    skybox: np.ndarray | None = None,
    **_ignored,
) -> list[str]:
    """Write ``out`` (``<stem>_sh.txt``), and beside it ``<stem>_ibl.ktx`` (given the cube
    chain ``levels``, made with the ``filament`` mapping), ``<stem>_skybox.ktx`` (given the
    mirror cube ``skybox``: the chain's sharp levels are fitted to Filament's blend, not shown
    alone) and, with a sun, ``<stem>_sun.json`` (with fitted lights,
    ``<stem>_lights.json``)."""
    require_sh(src, "filament")
    stem = out[: -len("_sh.txt")]
    sh = filament_sh(src.irradiance9)
    write_text(out, sh_text(sh))
    written = [out]
    if levels is not None:
        rough = roughness
        kv = {"sh": sh_metadata(sh), "shbake.roughness": json.dumps([round(r, 9) for r in rough])}
        for path, lv in ((stem + "_ibl.ktx", levels), (stem + "_skybox.ktx", [skybox])):
            lv = clamp_to_half(lv, path, limit=R11G11B10_MAX, kind="R11F_G11F_B10F")
            payload = encode_ktx1([filament_faces(x) for x in lv], kv)
            with atomic_path(path) as tmp, open(tmp, "wb") as f:
                f.write(payload)
            written.append(path)
    if src.sun_direction is not None:
        sun = _light_entry("SUN", src.sun_direction, src.sun_irradiance) | {
            "angular_radius_deg": float(
                np.degrees(np.arccos(1 - src.sun_solid_angle / (2 * np.pi)))
            ),
        }
        path = stem + "_sun.json"
        write_text(path, json.dumps(sun, indent=1, sort_keys=True) + "\n")
        written.append(path)
    elif src.lights:
        doc = {"lights": [_light_entry("DIRECTIONAL", d, e) for d, e in src.lights]}
        path = stem + "_lights.json"
        write_text(path, json.dumps(doc, indent=1, sort_keys=True) + "\n")
        written.append(path)
    return written


def _light_entry(kind: str, direction, irradiance) -> dict:
    """A ``LightManager`` light: travel direction, intensity in lux, linear colour."""
    e = np.asarray(irradiance, dtype=np.float64)
    intensity = float(e.max())
    return {
        "type": kind,
        "direction": [float(-v) for v in direction],
        "intensity_lux": intensity,
        "color_linear": [float(v) for v in (e / intensity if intensity > 0 else np.ones(3))],
    }


__all__ = [
    "CUBES",
    "MIN_ROUGHNESS",
    "basis_constants",
    "encode_ktx1",
    "filament_faces",
    "filament_sh",
    "pack_r11g11b10",
    "sh_metadata",
    "sh_text",
    "write",
]
