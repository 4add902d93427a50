"""Babylon.js export (``--to babylon``): the glTF of :mod:`.gltf` (``-o X.gltf``), or Babylon's own
prefiltered environment (``-o X.env``), read by ``CubeTexture.CreateFromPrefilteredData``.

The ``.env`` layout (npm @babylonjs/core 9.31.0 ``Misc/environmentTextureTools.pure.js``:
``GetEnvInfo`` 26–49, ``CreateRadianceImageDataArrayBufferViews`` 285–303,
``UploadEnvLevelsAsync`` 333–354, ``UploadEnvSpherical`` 643–660): the 8 magic bytes
``86 16 87 96 f6 d6 96 36``; a NUL-terminated ASCII JSON manifest ``{version: 2, width: N0,
imageType: "image/png", irradiance: {x, y, z, xx, yy, zz, yz, zx, xy}, specular: {mipmaps:
[{length, position}, …], lodGenerationScale}}``; then the images, level-major, face-minor,
``position`` counted from the byte after the NUL. Babylon refuses a chain that does not go
down to 1² (``6 × (log2 N0 + 1)`` images).

* Images: the same RGBD PNGs as the glTF's (:func:`.gltf.babylon_faces`: faces stored
  bottom row first, linear radiance), with no ``intensity``: a ``.env`` has none, so texels
  above RGBD's 255 are clamped with one warning (``--extract-sun`` sends a sun as a light).
  ``CreateFromPrefilteredData`` makes the texture with ``gammaSpace = false``
  (``Materials/Textures/cubeTexture.pure.js:222–223``): decoded once, nothing to set.
* Levels: the ``babylon`` mapping (:mod:`shbake.bakers.cube_prefilter`), ``α = 1`` at
  level ``k`` (8² faces by default) and ``lodGenerationScale = k/log2(N0)`` (as the glTF
  loader computes it), so level ``i`` holds ``α = N0^(i/k − 1)``; the levels below ``k``
  (to 1²) are that ``α = 1`` level box-filtered, read only for ``r > 1``.
* Irradiance: Babylon's ``SphericalPolynomial`` of the SH (:func:`babylon_polynomial`),
  the same the glTF loader builds from ``irradianceCoefficients``: Babylon shades
  ``E(−n_x, n_y, n_z)/π`` at its world normal ``n``.
* A sun (or any light) cannot go in a ``.env``: with one, ``STEM_lights.gltf`` holds it
  (:func:`.gltf.write_lights`), for ``AppendSceneAsync`` beside the ``.env``.
* Left-handed scenes only: a right-handed Babylon scene turns the environment 180° about
  +Y and a ``.env`` has no rotation to undo it (``--rotate 180`` does).
"""

import json
import math
import os

import numpy as np

from shbake.errors import ParameterError
from shbake.format.exports import gltf
from shbake.format.exports.filament import basis_constants
from shbake.format.exports.gltf import BABYLON_SIGNS
from shbake.format.exports.source import ExportSource, require_sh
from shbake.format.images import clamp_to_half
from shbake.sh.kernels import lambert_kernel

EXTENSION = ".gltf"
OUTPUT_ENDINGS = (".gltf", ".env")
CUBES = gltf.CUBES
"""The glTF's chain (256² faces, as Babylon's own ``.env`` files; ``α = 1`` at 8²); a ``.env``
continues it to 1² (:func:`shbake.bakers.cube_chain.extend_chain`)."""
ENV_MAGIC = bytes([0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36])
POLYNOMIAL_KEYS = ("x", "y", "z", "xx", "yy", "zz", "yz", "zx", "xy")


def babylon_polynomial(irradiance9: np.ndarray) -> dict:
    """Babylon's ``SphericalPolynomial`` (key → ``[r, g, b]``) for shbake irradiance SH ``E_i``
    (target frame): the one the glTF loader builds from ``irradianceCoefficients``.

    The loader turns the coefficients ``s_i E_i`` (:func:`.gltf.babylon_coefficients`) into
    Lambert radiance SH ``H_i = s_i E_i / π`` and ``SphericalPolynomial.updateFromHarmonics``
    (``Maths/sphericalPolynomial.pure.js:375–400``) writes ``H``'s cosine-convolved polynomial
    over π, each term ``c_i Â_l H_i / π`` (``1.02333 = c_1 Â_1``, ``0.858086 = c_2 Â_2``, …;
    exact values here): the shader gets ``H`` back (``preScaledHarmonics`` =
    ``SphericalHarmonics.FromPolynomial``, ``:271–287``, the inverse) and shades ``E(m)/π``
    at Babylon's normal ``n``, ``m = (−n_x, n_y, n_z)`` (:mod:`.gltf`).
    """
    h = BABYLON_SIGNS[:, None] * np.asarray(irradiance9, dtype=np.float64) / np.pi
    a_hat = lambert_kernel(2)[[0, 1, 1, 1, 2, 2, 2, 2, 2]]
    k = (basis_constants() * a_hat / np.pi)[:, None] * h
    poly = {
        "x": -k[3],
        "y": -k[1],
        "z": k[2],
        "xx": k[0] - k[6] + k[8],
        "yy": k[0] - k[6] - k[8],
        "zz": k[0] + 2.0 * k[6],
        "yz": -k[5],
        "zx": -k[7],
        "xy": k[4],
    }
    return {key: [float(v) for v in poly[key]] for key in POLYNOMIAL_KEYS}


def encode_env(width: int, faces_png: list[list[bytes]], manifest: dict) -> bytes:
    """``.env`` bytes: magic, the manifest (``specular.mipmaps`` filled in) and the images."""
    mipmaps, position = [], 0
    for level in faces_png:
        for png in level:
            mipmaps.append({"length": len(png), "position": position})
            position += len(png)
    doc = {**manifest, "version": 2, "width": int(width), "imageType": "image/png"}
    doc["specular"] = {**manifest["specular"], "mipmaps": mipmaps}
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"))  # ASCII: ensure_ascii
    return ENV_MAGIC + text.encode("ascii") + b"\0" + b"".join(b"".join(lv) for lv in faces_png)


def write_env(src: ExportSource, out: str, levels, roughness, mapping: str, babylon_scene: str):
    """Write ``out`` (``.env``) and, with a sun, ``STEM_lights.gltf``; returns the paths."""
    if babylon_scene != "left-handed":
        raise ParameterError(
            f"{out}: a .env has no rotation for a right-handed Babylon scene (it turns the "
            "environment 180° about +Y); export with --rotate 180 instead"
        )
    if mapping != "babylon":
        raise ParameterError(
            f"{out}: a .env is read with Babylon's roughness per level: --lod-mapping babylon"
        )
    width = int(levels[0].shape[1])
    if width < 2 or int(levels[-1].shape[1]) != 1:
        raise ParameterError(f"{out}: a .env holds a chain from --size ≥ 2 down to 1²")
    rough_level = int(np.argmax(roughness))  # the first α = 1 level: lod s·log2(N0)
    levels = clamp_to_half(levels, out, limit=gltf.RGBD_MAX, kind="RGBD (.env)")
    faces_png = [[gltf.png_rgba8(f) for f in gltf.babylon_faces(lv)] for lv in levels]
    manifest = {
        "irradiance": babylon_polynomial(src.irradiance9),
        "specular": {"lodGenerationScale": rough_level / math.log2(width)},
        "shbake": {
            "specular_roughness": [round(float(r), 9) for r in roughness],
            "roughness_lod_mapping": mapping,
            "frame": src.frame,
        },
    }
    gltf.write_bytes(out, encode_env(width, faces_png, manifest))
    written = [out]
    lights = os.path.splitext(out)[0] + "_lights.gltf"
    if gltf.write_lights(src, lights):
        written.append(lights)
    return written


def write(
    src: ExportSource,
    out: str,
    levels: list[np.ndarray],
    roughness: list[float],
    mapping: str = "babylon",
    babylon_scene: str = "left-handed",
    **_ignored,
) -> list[str]:
    """``out`` ending ``.env``: :func:`write_env`; ``.gltf``: the glTF (:func:`.gltf.write`)."""
    if out.endswith(".gltf"):
        return gltf.write(src, out, levels, roughness, mapping, babylon_scene)
    require_sh(src, "babylon")
    return write_env(src, out, levels, roughness, mapping, babylon_scene)


__all__ = [
    "CUBES",
    "EXTENSION",
    "OUTPUT_ENDINGS",
    "babylon_polynomial",
    "encode_env",
    "write",
    "write_env",
]
