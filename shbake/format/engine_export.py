"""Exports of irradiance SH to engine formats.

glTF ``EXT_lights_image_based``: ``irradianceCoefficients`` is a 9×3 array
(rows in the order ``l(l+1)+m``, columns RGB). shbake writes its
``/irradiance/sh`` values: the lighting convolved with the clamped cosine
(``Â_l`` folded in), so that ``E(n) = Σ_i c_i y_i(n)`` in the basis of
``docs/CONVENTIONS.md``; a Lambert surface of albedo ``ρ`` has radiance
``ρ E(n) / π``. The light's frame is glTF's (+Y up, right-handed), the same
as shbake's.
"""

import json

import numpy as np

from shbake.format.atomic import write_text


def gltf_light(irradiance9: np.ndarray, name: str, intensity: float = 1.0) -> dict:
    """A ``EXT_lights_image_based`` light object holding ``irradianceCoefficients``."""
    c = np.asarray(irradiance9, dtype=np.float64)
    if c.shape != (9, 3):
        raise ValueError(f"glTF irradiance needs 9×3 coefficients, got {c.shape}")
    return {
        "name": name,
        "intensity": intensity,
        "rotation": [0.0, 0.0, 0.0, 1.0],
        "irradianceCoefficients": [[float(v) for v in row] for row in c],
        "extras": {
            "shbake:normalisation": "E(n) = sum_i c_i y_i(n); Lambert radiance = albedo * E / pi",
            "shbake:sh_basis": "real orthonormal, no Condon-Shortley phase, index l(l+1)+m",
        },
    }


def write_gltf_json(path: str, irradiance9: np.ndarray, name: str) -> None:
    """Write ``{"extensions": {"EXT_lights_image_based": {"lights": [...]}}}`` to ``path``."""
    doc = {"extensions": {"EXT_lights_image_based": {"lights": [gltf_light(irradiance9, name)]}}}
    write_text(path, json.dumps(doc, indent=2, sort_keys=True) + "\n")
