"""Lafortune et al. (1997) generalised cosine lobes, three lobes plus a diffuse term.

``f(s, v) = ρ_d/π + Σ_k max(0, C_xy,k (s_x v_x + s_y v_y) + C_z,k s_z v_z)^{n_k}`` (1/sr),
per colour channel, in the local frame (normal +Z). Isotropic (``C_x = C_y``).
The defaults are the fit to human skin measured by Marschner et al. (2000),
the BRDF that Ramamoorthi & Hanrahan (2002, §7.1) use, as tabulated (per
R, G, B) in pbrt v1's ``skin`` material. The model is not energy-normalised;
its albedo is measured where needed, not guaranteed ≤ 1.
Lobe sampling: the Phong lobe of the sharpest lobe's exponent about the
mirror direction (a valid density/sampler pair).
"""

import numpy as np

from shbake.brdf.phong import mirror_lobe_pdf, mirror_lobe_sample
from shbake.brdf.spec import ModelSpec, Param
from shbake.jit import jit

SKIN = {
    "rho_d": (0.428425, 0.301341, 0.331054),
    "cxy1": (-1.131747, -1.016939, -0.966018),
    "cz1": (-1.209182, -1.462488, -1.222419),
    "n1": (6.421658, 3.699932, 3.524889),
    "cxy2": (-0.546570, -0.643533, -0.638934),
    "cz2": (0.380123, 0.410559, 0.437367),
    "n2": (3.685044, 4.266495, 4.539742),
    "cxy3": (-0.998888, -1.020153, -1.027479),
    "cz3": (0.857998, 0.703913, 0.573625),
    "n3": (64.208486, 63.919687, 43.809866),
}
"""Skin (Marschner et al. 2000) per channel R, G, B."""

_DOC = {"cxy": "lateral coefficient C_x = C_y", "cz": "normal coefficient C_z", "n": "exponent"}
_RANGE = {"cxy": (-10.0, 10.0), "cz": (-10.0, 10.0), "n": (0.0, 1e4)}

LOBE_PEAK_LIMIT = 1e8
"""Largest value (1/sr) a lobe may reach, ``max(|C_xy|, |C_z|)^n``: a normalised lobe of
exponent 10⁴ peaks near 1600; beyond this the float32 table overflows (``10^10000``)."""


def _lobe_peaks(values: dict) -> str | None:
    """The reason a lobe's peak exceeds :data:`LOBE_PEAK_LIMIT`, else ``None``."""
    for i in (1, 2, 3):
        c = np.maximum(np.abs(values[f"cxy{i}"]), np.abs(values[f"cz{i}"]))
        log_peak = values[f"n{i}"] * np.log10(np.maximum(c, 1e-300))
        if np.any(log_peak > np.log10(LOBE_PEAK_LIMIT)):
            return (f"lobe {i} peaks at max(|cxy{i}|, |cz{i}|)^n{i} = 10^{np.max(log_peak):.4g} "
                    f"1/sr, above {LOBE_PEAK_LIMIT:g}: lower n{i} or the coefficients")
    return None


SPEC = ModelSpec(
    name="lafortune",
    model_id=9,
    params=(Param("rho_d", SKIN["rho_d"], 0.0, 1.0, colour=True, doc="diffuse albedo"),)
    + tuple(
        Param(f"{k}{i}", SKIN[f"{k}{i}"], *_RANGE[k], colour=True, doc=f"lobe {i}: {_DOC[k]}")
        for i in (1, 2, 3)
        for k in ("cxy", "cz", "n")
    ),
    citation="E. Lafortune, S.-C. Foo, K. Torrance, D. Greenberg, Non-linear approximation "
    "of reflectance functions, SIGGRAPH 1997; skin fit: S. Marschner et al., Image-based "
    "BRDF measurement including human skin, EGWR 2000 (values as in pbrt v1)",
    summary="three generalised cosine lobes + diffuse (default: human skin)",
    check=_lobe_peaks,
)


@jit
def evaluate(prm, sx, sy, sz, vx, vy, vz, out):
    """Radiometric BRDF value per channel; ``prm = (ρ_d[3], (C_xy[3], C_z[3], n[3]) × 3)``."""
    lat = sx * vx + sy * vy
    nor = sz * vz
    for c in range(3):
        f = prm[c] / np.pi
        for k in range(3):
            base = 3 + 9 * k
            x = prm[base + c] * lat + prm[base + 3 + c] * nor
            if x > 0.0:
                f += np.exp(prm[base + 6 + c] * np.log(x))
        out[c] = f


@jit
def _sharpest(prm):
    n = 1.0
    for k in range(3):
        for c in range(3):
            n = max(n, prm[3 + 9 * k + 6 + c])
    return n


@jit
def sample(prm, vx, vy, vz, ur, ua):
    """A direction from the Phong lobe of the largest exponent about the mirror direction."""
    return mirror_lobe_sample(_sharpest(prm), vx, vy, vz, ur, ua)


@jit
def pdf(prm, sx, sy, sz, vx, vy, vz):
    """Density of :func:`sample` (1/sr)."""
    return mirror_lobe_pdf(_sharpest(prm), sx, sy, sz, vx, vy, vz)
