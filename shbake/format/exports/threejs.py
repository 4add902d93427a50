"""three.js export: an ``ObjectLoader`` JSON scene, ``LightProbe`` + ``DirectionalLight`` sun.

three.js conventions (``docs/EXPORTS.md``; checked by ``tests/format/exports/test_threejs.py``
with three's own ``ObjectLoader``, ``SphericalHarmonics3.getIrradianceAt``):

* ``LightProbe.sh`` holds **radiance** SH (``src/lights/LightProbe.js``;
  ``SphericalHarmonics3.getIrradianceAt`` folds in ``π, 2π/3, π/4`` itself), in
  the basis and order of shbake (``y_1 ∝ y, y_2 ∝ z, y_3 ∝ x``, no
  Condon–Shortley sign: ``src/math/SphericalHarmonics3.js`` ``getAt``):
  ``sh = /lighting/sh[:9]`` unchanged, flattened coefficient-major (27 floats,
  ``SphericalHarmonics3.toArray``). Feeding it ``/irradiance/sh`` would apply
  the cosine kernel twice.
* three's world is right-handed, +Y up: shbake's frame.
* The sun: three ``DirectionalLight`` s (pure red, green, blue) at the unit sun
  direction, aimed at the origin (their default target), whose ``intensity``
  is that channel of the sun's irradiance: three's physically based lights give
  irradiance ``color × intensity × max(0, n·l)`` with no π
  (``lights_pars_begin.glsl``, ``RE_Direct``), a Lambert surface ``ρ/π`` of it,
  as of the probe's irradiance. One light per channel because ``Object3D.toJSON``
  writes ``color`` as a ``0xRRGGBB`` integer (8 bits per channel), which would
  quantise the sun's colour.
* Fitted lights (``project-env --lights``): three ``DirectionalLight`` s per light,
  the same way, named ``<name> light <k> <channel>``; ``LightProbe.sh`` is then the
  fitted residual (``/lighting/sh``, bands 0–2 = fitted irradiance / ``Â_l``).
* The probe's position (``probe_position`` of a scene probe, target frame) is the
  ``LightProbe``'s translation (``matrix`` elements 12–14, column-major); the sun
  lights are the scene's children, not the probe's, so they do not move with it.

Glossy lighting for three is the ``threejs-pmrem`` target (:mod:`.three_pmrem`).
"""

import json

import numpy as np

from shbake.errors import ParameterError
from shbake.format.atomic import write_text
from shbake.format.exports.source import ExportSource, require_sh

CUBES = None
"""No cube maps."""
EXTENSION = ".json"
OUTPUT_ENDINGS = None
_UUID = "00000000-0000-4000-8000-{:012d}"


def probe_array(lighting9: np.ndarray) -> list[float]:
    """``LightProbe.sh.toArray()`` for shbake radiance SH (9×3): coefficient-major, 27 floats."""
    c = np.asarray(lighting9, dtype=np.float64)
    if c.shape != (9, 3):
        raise ParameterError(f"three.js LightProbe needs 9x3 radiance SH, got {c.shape}")
    return [float(v) for v in c.reshape(-1)]


def scene_json(src: ExportSource) -> dict:
    """The ``ObjectLoader`` document (``metadata`` + ``object``) for one source."""
    at = [0.0, 0.0, 0.0] if src.position is None else [float(v) for v in src.position]
    children = [
        {
            "uuid": _UUID.format(2),
            "type": "LightProbe",
            "name": f"{src.name} probe",
            "layers": 1,
            "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, *at, 1],
            "up": [0, 1, 0],
            "color": 0xFFFFFF,
            "intensity": 1.0,
            "sh": probe_array(src.lighting9),
        }
    ]
    for j, (direction, irradiance) in enumerate(src.lights):
        d = [float(v) for v in direction]
        light = "sun" if src.sun_direction is not None else f"light {j}"
        for k, (name, colour) in enumerate(
            (("red", 0xFF0000), ("green", 0x00FF00), ("blue", 0x0000FF))
        ):
            children.append(
                {
                    "uuid": _UUID.format(3 + 3 * j + k),
                    "type": "DirectionalLight",
                    "name": f"{src.name} {light} {name}",
                    "layers": 1,
                    "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, d[0], d[1], d[2], 1],
                    "up": [0, 1, 0],
                    "color": colour,
                    "intensity": float(irradiance[k]),
                }
            )
    return {
        "metadata": {"version": 4.6, "type": "Object", "generator": "shbake export"},
        "object": {
            "uuid": _UUID.format(1),
            "type": "Scene",
            "name": src.name,
            "layers": 1,
            "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],
            "up": [0, 1, 0],
            "children": children,
            "userData": {
                "shbake": {
                    "frame": src.frame,
                    "sh": "radiance SH L_lm (three.js LightProbe); getIrradianceAt gives E(n)",
                    "sun_irradiance": None
                    if src.sun_irradiance is None
                    else [float(v) for v in src.sun_irradiance],
                }
                | (
                    {}
                    if src.light_irradiance is None
                    else {
                        "lights_irradiance": [[float(v) for v in e] for e in src.light_irradiance]
                    }
                )
            },
        },
    }


def write(src: ExportSource, out: str, **_ignored) -> list[str]:
    """Write the three.js scene JSON to ``out``."""
    require_sh(src, "threejs")
    write_text(out, json.dumps(scene_json(src), indent=1, sort_keys=True) + "\n")
    return [out]
