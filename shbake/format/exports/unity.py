"""Unity export: ``SphericalHarmonicsL2`` coefficients in Unity's packing, frame and scale.

Unity's conventions (``docs/EXPORTS.md``), from Unity's own scripts; Unity is
not run by the tests:

* ``sh[c, i]`` (``c`` = R, G, B; ``i`` = 0…8) is read by the SRP core
  ``SHCoefficients`` / HDRP ``SphericalHarmonicMath.PackCoefficients`` as
  ``unity_SHA = (sh3, sh1, sh2, sh0 − sh6)``, ``unity_SHB = (sh4, sh5, 3 sh6, sh7)``,
  ``unity_SHC = sh8``; the shader (``SHEvalLinearL0L1`` + ``SHEvalLinearL2``)
  then evaluates ``sh0 + sh1 y + sh2 z + sh3 x + sh4 xy + sh5 yz + sh6 (3z²−1)
  + sh7 xz + sh8 (x²−y²)``, which multiplies the albedo: the Lambert radiance
  ``E(n)/π``.
* Stored probes are "premultiplied": HDRP's ``SphericalHarmonicMath`` turns
  them back into radiance SH with ``invNormConsts = 1 / (k_i Â_l / π)``, with
  Condon–Shortley-signed ``k_i`` (negative for m = ±1) — and the basis it
  projects on carries the same sign, so the signs cancel:
  ``sh[c, i] = E_i |k_i| / π`` (shbake ``E_i``, ``|k_i|`` shbake's basis
  constants).
* Frame: Unity is left-handed, +Y up. shbake's right-handed +Y-up world maps to
  it by mirroring X (what UnityGLTF, ``CoordinateSpaceConversionScale = (−1, 1, 1)``,
  and glTFast do when importing glTF): ``n_unity = (−x, y, z)``; the x-odd
  functions (indices 3, 4, 7) change sign.
* Sun: a directional light whose transform's +Z (the way the light travels)
  is ``−d`` in Unity's frame; ``intensity_builtin`` = largest channel of
  ``E_sun / π`` (built-in pipeline lights have no 1/π: diffuse = albedo ×
  colour × intensity × n·l) and ``intensity_lux`` = largest channel of ``E_sun``
  (HDRP, physical units); ``color`` = ``E_sun`` / its largest channel.
* Fitted lights (``project-env --lights``): ``lights``, one such entry per light.
"""

import json

import numpy as np

from shbake.format.atomic import write_text
from shbake.format.exports.filament import basis_constants
from shbake.format.exports.source import ExportSource, require_sh

CUBES = None
"""No cube maps."""
EXTENSION = ".unity.json"
OUTPUT_ENDINGS = None
UNITY_FROM_WORLD = np.diag([-1.0, 1.0, 1.0])
X_ODD = np.array([1, 1, 1, -1, -1, 1, 1, -1, 1], dtype=np.float64)
"""Sign of each shbake basis polynomial under ``x → −x`` (indices 3, 4, 7 are odd in x)."""


def unity_sh(irradiance9: np.ndarray) -> np.ndarray:
    """``SphericalHarmonicsL2`` ``sh[c, i]`` (3×9) of shbake irradiance SH ``E_i`` (9×3)."""
    e = np.asarray(irradiance9, dtype=np.float64)
    return (e * (X_ODD * basis_constants() / np.pi)[:, None]).T


def _directional(direction, irradiance) -> dict:
    """A directional light entry: ``forward`` (Unity frame), colour and intensities."""
    e = np.asarray(irradiance, dtype=np.float64)
    top = float(e.max())
    d = UNITY_FROM_WORLD @ np.asarray(direction, dtype=np.float64)
    return {
        "forward": [float(-v) for v in d],
        "color": [float(v) for v in (e / top if top > 0 else np.ones(3))],
        "intensity_builtin": top / np.pi,
        "intensity_lux": top,
    }


def write(src: ExportSource, out: str, **_ignored) -> list[str]:
    """Write ``out``: the SH (``sh[c][i]``) and the sun for Unity, as JSON."""
    require_sh(src, "unity")
    doc = {
        "SphericalHarmonicsL2": [[float(v) for v in row] for row in unity_sh(src.irradiance9)],
        "layout": "sh[channel][coefficient], channel R,G,B; coefficient order 1, y, z, x, xy, yz, "
        "3z^2-1, xz, x^2-y^2; evaluates to E(n)/pi in Unity's left-handed frame (x mirrored)",
        "frame": src.frame,
    }
    if src.position is not None:  # a LightProbeGroup's probePositions entry, Unity's frame
        doc["position"] = [float(v) for v in UNITY_FROM_WORLD @ src.position]
    entries = [_directional(d, e) for d, e in src.lights]
    if src.sun_direction is not None:
        doc["sun"] = entries[0]
    elif entries:
        doc["lights"] = entries
    write_text(out, json.dumps(doc, indent=1, sort_keys=True) + "\n")
    return [out]
