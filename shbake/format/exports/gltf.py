"""glTF 2.0 export: ``EXT_lights_image_based`` + ``KHR_lights_punctual`` sun, as Babylon reads it.

The extension's text (KhronosGroup/glTF ``extensions/2.0/Vendor/EXT_lights_image_based/README.md``)
defines no SH basis, sign or normalisation; Babylon.js is its implementation,
so the numbers are written for what Babylon computes (``docs/EXPORTS.md``,
each step checked in Babylon's own code by ``tests/format/exports/test_gltf.py``):

* ``irradianceCoefficients[i] = s_i E_i / intensity²`` with ``s = (+,−,+,+,−,−,+,+,+)``:
  Babylon's basis carries the Condon–Shortley sign (``SH3ylmBasisConstants``
  negate ``y, x, yz, xz``) and its loader mirrors glTF ``x`` into its
  left-handed frame; together they read shbake's ``E(x, −y, z)``, which the
  sign flips of the ``y``-odd functions (indices 1, 4, 5) undo.
* Babylon scales the SH by ``intensity`` (``EXT_lights_image_based.ts``:
  ``sphericalHarmonics.scaleInPlace(light.intensity)``) *and* multiplies the
  shaded irradiance by ``texture.level = intensity`` (``pbrBlockReflection``:
  ``environmentIrradiance *= vReflectionInfos.x``): ``intensity²`` in all.
* It divides by π (``convertIrradianceToLambertianRadiance``) and multiplies by
  the albedo: a Lambert surface shows ``ρ E / π``, so the coefficients are
  irradiance ``E`` (radiance × sr, "lux").
* ``specularImages``: shbake's GGX prefiltered cube mip chain
  (:mod:`shbake.bakers.cube_prefilter`), levels at the roughness Babylon's shader
  reads each one for (``mapping = "babylon"``: ``lod = s · log2(N0 (r² + 0.0005))``,
  the loader's ``lodGenerationScale s = (levels − 1)/log2(N0)``), RGBD PNGs (the
  extension's HDR packing: ``rgb = (c·D)^(1/2.2)``, ``a = D``,
  ``D = floor(max(255/max(c), 1))/255``, Babylon's ``toRGBD``), faces +X, −X, +Y,
  −Y, +Z, −Z, **each stored bottom row first** (:func:`babylon_faces`): Babylon
  uploads an image's top row at the face's ``t = 1`` edge, GL's last row. Babylon's
  left-handed world is shbake's with ``x`` mirrored (the loader's root node), so it
  samples world ``d`` at GL ``(−d_x, d_y, d_z)``, shbake's cube convention.
  ``intensity`` is the power of two that brings the brightest texel within
  RGBD's range 255 (1 when it already is); images store ``radiance / intensity``.
  The loader leaves the texture's ``gammaSpace = true`` (a ``RawCubeTexture``), so
  the shader would gamma-decode the already linear radiance once more
  (``GAMMAREFLECTION``): the snippet of ``docs/EXPORTS.md`` sets it to ``false``.
* With an extracted sun: a ``KHR_lights_punctual`` directional light whose
  node's +Z points at the sun (glTF lights shine along −Z), ``intensity``
  = the largest channel of its irradiance (lux) and ``color`` = irradiance /
  intensity; the IBL holds the residual, so ``E_ibl + E_sun`` is the map's irradiance.
  Fitted lights (``project-env --lights``): one such light and node per light.
"""

import json
import math
import os
import struct
import urllib.parse

import numpy as np

from shbake.errors import ParameterError
from shbake.format.atomic import atomic_path, write_text
from shbake.format.exports.source import ExportSource, require_sh

EXTENSION = ".gltf"
OUTPUT_ENDINGS = (".gltf",)
BABYLON_SCENES = ("left-handed", "right-handed")
"""Handedness of the Babylon.js scene that loads the file (``--babylon-scene``)."""
BABYLON_SIGNS = np.array([1, -1, 1, 1, -1, -1, 1, 1, 1], dtype=np.float64)
"""Per-coefficient sign from shbake's basis to Babylon's reading (indices 1, 4, 5 flip)."""
RGBD_MAX = 255.0
GAMMA = 2.2


def rgbd_intensity(levels: list[np.ndarray]) -> float:
    """The power of two (≥ 1) that brings the chain's brightest texel within RGBD's 255."""
    peak = max(float(np.max(lv)) for lv in levels)
    return 1.0 if peak <= RGBD_MAX else float(2.0 ** math.ceil(math.log2(peak / RGBD_MAX)))


def babylon_coefficients(irradiance9: np.ndarray, intensity: float = 1.0) -> np.ndarray:
    """``irradianceCoefficients`` (9×3) for shbake irradiance SH ``E_i`` (glTF frame)."""
    return BABYLON_SIGNS[:, None] * np.asarray(irradiance9, dtype=np.float64) / intensity**2


def rgbd_encode(img: np.ndarray) -> np.ndarray:
    """Linear HDR ``(…, 3)`` → RGBD ``uint8 (…, 4)`` as Babylon's ``toRGBD``."""
    c = np.maximum(np.asarray(img, dtype=np.float64), 0.0)
    m = np.maximum(c.max(axis=-1), 1e-6)
    D = np.clip(np.floor(np.maximum(RGBD_MAX / m, 1.0)) / 255.0, 0.0, 1.0)
    rgb = np.clip((c * D[..., None]) ** (1.0 / GAMMA), 0.0, 1.0)
    out = np.concatenate([rgb, D[..., None]], axis=-1)
    return np.round(out * 255.0).astype(np.uint8)


def babylon_faces(level: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """One cube level ``(6, n, n, 3)`` (shbake's GL face orientation, radiance ``× scale``)
    as the RGBD images Babylon.js uploads: ``uint8 (6, n, n, 4)``, rows bottom first."""
    return rgbd_encode(np.asarray(level, dtype=np.float64)[:, ::-1] * scale)


def png_rgba8(px: np.ndarray) -> bytes:
    """An 8-bit RGBA image ``(h, w, 4)`` as PNG bytes (PNG 1.2: no colour chunk, filter 0,
    zlib level 9; the same pixels give the same bytes)."""
    import zlib

    px = np.ascontiguousarray(px, dtype=np.uint8)
    h, w, _ = px.shape
    rows = np.concatenate([np.zeros((h, 1), np.uint8), px.reshape(h, 4 * w)], axis=1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), 9)) + chunk(b"IEND", b""))  # fmt: skip


def write_bytes(path: str, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (:func:`shbake.format.atomic.atomic_path`)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(data)


def _quat_z_to(d: np.ndarray) -> list[float]:
    """Unit quaternion ``[x, y, z, w]`` turning +Z onto unit ``d``."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(np.dot(z, d))
    if c < -1.0 + 1e-12:
        return [1.0, 0.0, 0.0, 0.0]
    axis = np.cross(z, d)
    w = math.sqrt(0.5 * (1.0 + c))
    q = np.concatenate([axis / (2.0 * w), [w]])
    q /= np.linalg.norm(q)
    return [float(v) for v in q]


def punctual_lights(src: ExportSource) -> list[tuple[dict, dict]]:
    """The ``KHR_lights_punctual`` light and its node for each of the source's lights."""
    out = []
    for j, (direction, e) in enumerate(src.lights):
        intensity = float(e.max())
        color = [float(v) for v in (e / intensity if intensity > 0 else np.ones(3))]
        name = f"{src.name} sun" if src.sun_direction is not None else f"{src.name} light {j}"
        light = {"type": "directional", "name": name, "color": color, "intensity": intensity}
        node = {
            "name": name,
            "rotation": _quat_z_to(np.asarray(direction, dtype=np.float64)),
            "extensions": {"KHR_lights_punctual": {"light": j}},
        }
        out.append((light, node))
    return out


CUBES = {"size": 256, "floor": 8, "samples": 512, "mapping": "babylon"}
"""Default specular chain: 256² to 8² faces at Babylon's roughness per level (``α = 1`` at
8²: Babylon blends two bilinear levels, and 4² or 2² faces are too coarse for the rough
lobes: forest r 0.6, 4.5 % median with the chain down to 1², 0.8 % down to 8²).
``--lod-mapping gltf-ibl-sampler`` spaces the levels evenly in roughness 0…1, the
extension's text, for other viewers."""


def write(
    src: ExportSource,
    out: str,
    levels: list[np.ndarray],
    roughness: list[float],
    mapping: str = "babylon",
    babylon_scene: str = "left-handed",
    **_ignored,
) -> list[str]:
    """Write ``out`` (.gltf) and its specular PNGs beside it; returns the paths written.

    ``levels``/``roughness``: the GGX prefiltered cube chain in the target frame
    (:func:`shbake.bakers.cube_chain.prefilter_chain`) and each level's
    perceptual roughness; ``mapping`` names the roughness↔LOD rule it used.

    ``babylon_scene``: ``left-handed`` (Babylon's default scene) or
    ``right-handed`` (``scene.useRightHandedSystem = true``): there the loader
    skips its x mirror and the shader flips z (``REFLECTIONMAP_OPPOSITEZ``), which
    turns the irradiance 180° about +Y; the light's ``rotation`` is then
    ``[0, 1, 0, 0]`` to undo it.
    """
    require_sh(src, "gltf")
    if babylon_scene not in BABYLON_SCENES:
        raise ParameterError(
            f"babylon scene must be left-handed or right-handed, got {babylon_scene!r}"
        )
    rough = roughness
    size = int(levels[0].shape[1])
    intensity = rgbd_intensity(levels)
    stem = os.path.splitext(os.path.basename(out))[0]
    directory = os.path.dirname(os.path.abspath(out))
    images, spec, written = [], [], []
    for m, lv in enumerate(levels):
        faces, faces_rgbd = [], babylon_faces(lv, 1.0 / intensity)
        for f in range(6):
            name = f"{stem}_specular_{m}_{f}.png"
            path = os.path.join(directory, name)
            write_bytes(path, png_rgba8(faces_rgbd[f]))
            written.append(path)
            faces.append(len(images))
            # a URI reference (RFC 3986): a name's space, "#", "?" or "%" percent-encoded
            images.append({"uri": urllib.parse.quote(name, safe=""), "mimeType": "image/png"})
        spec.append(faces)
    ibl = {
        "name": src.name,
        "intensity": intensity,
        "rotation": [0.0, 0.0, 0.0, 1.0]
        if babylon_scene == "left-handed"
        else [0.0, 1.0, 0.0, 0.0],
        "irradianceCoefficients": [
            [float(v) for v in row] for row in babylon_coefficients(src.irradiance9, intensity)
        ],
        "specularImageSize": int(size),
        "specularImages": spec,
        "extras": {
            "shbake": {
                "irradiance_sh_shbake_basis": [[float(v) for v in row] for row in src.irradiance9],
                "basis": "Babylon.js: coefficient i = sign_i * E_i / intensity^2, "
                "sign = (+,-,+,+,-,-,+,+,+)",
                "specular_roughness": [float(r) for r in rough],
                "roughness_lod_mapping": mapping,
                "frame": src.frame,
            }
        },
    }
    doc = {
        "asset": {"version": "2.0", "generator": "shbake export"},
        "extensionsUsed": ["EXT_lights_image_based"],
        "extensions": {"EXT_lights_image_based": {"lights": [ibl]}},
        "images": images,
        "nodes": [{"name": f"{src.name} environment"}],
        "scene": 0,
        "scenes": [
            {"name": src.name, "nodes": [0], "extensions": {"EXT_lights_image_based": {"light": 0}}}
        ],
    }
    add_lights(doc, src)
    write_text(out, json.dumps(doc, indent=1, sort_keys=True) + "\n")
    return [out, *written]


def add_lights(doc: dict, src: ExportSource) -> bool:
    """Add the source's lights (``KHR_lights_punctual``) to glTF ``doc``'s scene 0; False
    when it has none."""
    lights = punctual_lights(src)
    if not lights:
        return False
    doc["extensionsUsed"].append("KHR_lights_punctual")
    doc.setdefault("extensions", {})["KHR_lights_punctual"] = {
        "lights": [light for light, _ in lights]
    }
    for _, node in lights:
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]))
        doc["nodes"].append(node)
    return True


def write_lights(src: ExportSource, out: str) -> bool:
    """A glTF holding only the source's lights (beside a Babylon ``.env``); False, and
    nothing written, when it has none."""
    doc = {
        "asset": {"version": "2.0", "generator": "shbake export"},
        "extensionsUsed": [],
        "nodes": [],
        "scene": 0,
        "scenes": [{"name": src.name, "nodes": []}],
    }
    if not add_lights(doc, src):
        return False
    write_text(out, json.dumps(doc, indent=1, sort_keys=True) + "\n")
    return True
