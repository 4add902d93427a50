"""Extraction of the dominant compact light ("sun") from an environment map.

The top complaint about SH lighting from HDR maps is the sun: a 0.5° disc
holding most of the energy rings through every band and drives the
irradiance negative on the far side. shbake removes it before projecting:

1. the peak texel (Rec.709 luminance) gives a first direction ``d0``;
2. the background colour ``B`` is the per-channel median of the annulus
   ``R < angle(d, d0) < 2R``;
3. every texel within ``R`` of ``d0`` gives its excess ``max(L - B, 0)`` to
   the light and keeps ``min(L, B)`` in the residual map;
4. the light is stored as a directional light: energy-weighted mean
   direction, solid angle of the texels that gave excess, and RGB radiance
   ``excess / solid angle`` (so ``radiance × solid_angle`` is its irradiance
   at normal incidence).

A map whose peak is less than ``min_contrast`` times the background has no
compact light; nothing is extracted.
"""

from typing import NamedTuple

import numpy as np

from shbake.conventions import REC709_LUMINANCE
from shbake.envmap.environment import Environment
from shbake.errors import ParameterError

SUN_RADIUS_MAX_DEG = 45.0
"""Largest angular radius of an extracted light, degrees."""
SUN_RADIUS_DEG = 10.0
"""Angular radius an extracted light is taken from unless asked otherwise (``--sun-radius``,
every scene bake), degrees."""


class Sun(NamedTuple):
    """A directional light: unit ``direction`` (toward the light, world frame),
    ``solid_angle`` (sr), ``radiance`` (RGB), ``energy = radiance × solid_angle``."""

    direction: np.ndarray
    solid_angle: float
    radiance: np.ndarray

    @property
    def energy(self) -> np.ndarray:
        return self.radiance * self.solid_angle


def _cap_and_background(dirs, mask, px, d0, radius_deg: float):
    """The texels within ``radius_deg`` of ``d0`` and the background colour: the
    per-channel median of the annulus ``R < angle < 2R`` (zero if it holds no texel)."""
    cos_r = np.cos(np.radians(radius_deg))
    cos_2r = np.cos(np.radians(2.0 * radius_deg))
    cosang = dirs @ d0
    annulus = mask & (cosang < cos_r) & (cosang >= cos_2r)
    background = np.median(px[annulus], axis=0) if annulus.any() else np.zeros(3)
    return mask & (cosang >= cos_r), background


def _excess(px, cap, background):
    """``max(L − B, 0)`` per channel on the texels of ``cap``, 0 elsewhere (float64, the
    map's shape): computed on the cap's texels only."""
    excess = np.zeros(px.shape)
    excess[cap] = np.maximum(px[cap] - background, 0.0)
    return excess


def remove_lights(
    env: Environment,
    directions: np.ndarray,
    irradiance: np.ndarray,
    radius_deg: float = SUN_RADIUS_DEG,
) -> tuple[Environment, dict]:
    """The map less the energy of given directional lights, taken from around each.

    For lights fitted to the irradiance (:mod:`shbake.bakers.env_lights`), whose
    energy the map holds as compact bright regions: for each light, brightest first,
    the texels within ``radius_deg`` of its direction give a share of their excess over
    the background (as in :func:`extract_sun`), the same fraction of each texel's
    excess per channel, until the light's irradiance ``E_k`` (radiance × sr, by the
    projection's quadrature weights) is removed or the excess is spent.

    Returns
    -------
    (residual, report)
        ``report``: ``removed`` (K, 3) per light, ``shortfall_fraction`` — the
        luminance of ``Σ E_k`` not found near the lights over that of ``Σ E_k``.
    """
    if not 0.0 < radius_deg <= 45.0:
        raise ParameterError(f"light radius must be in (0, 45] degrees, got {radius_deg}")
    dirs, _, mask = env.texels()
    weights = env.quadrature_weights()
    px = env.pixels.astype(np.float64)
    wanted = np.asarray(irradiance, dtype=np.float64).reshape(-1, 3)
    removed = np.zeros_like(wanted)
    for k in np.argsort(-(wanted @ REC709_LUMINANCE), kind="stable"):
        cap, background = _cap_and_background(dirs, mask, px, np.asarray(directions[k]),
                                               radius_deg)  # fmt: skip
        excess = _excess(px, cap, background)
        available = np.einsum("hwc,hw->c", excess, weights)
        share = np.where(available > 0.0, np.minimum(1.0, wanted[k] / np.where(
            available > 0.0, available, 1.0)), 0.0)  # fmt: skip
        px = px - excess * share
        removed[k] = available * share
    total = float(wanted.sum(axis=0) @ REC709_LUMINANCE)
    short = float((wanted - removed).sum(axis=0) @ REC709_LUMINANCE)
    report = {"removed": removed, "shortfall_fraction": short / total if total > 0 else 0.0}
    return Environment(px.astype(np.float32), env.layout, dict(env.meta)), report


def extract_sun(
    env: Environment, radius_deg: float = SUN_RADIUS_DEG, min_contrast: float = 20.0
) -> tuple[Sun | None, Environment, dict]:
    """Split ``env`` into a :class:`Sun` and a residual environment.

    Parameters
    ----------
    radius_deg : float, (0, SUN_RADIUS_MAX_DEG]
        Largest angular radius of the light, degrees.
    min_contrast : float, > 1
        Peak-to-background luminance ratio below which no light is extracted.

    Returns
    -------
    (sun or None, residual, report)
        ``report`` holds the peak, background, contrast and the fraction of
        ``∫ L dω`` moved into the light.
    """
    if not 0.0 < radius_deg <= SUN_RADIUS_MAX_DEG:
        raise ParameterError(
            f"sun radius must be in (0, {SUN_RADIUS_MAX_DEG:g}] degrees, got {radius_deg}"
        )
    if not min_contrast > 1.0:
        raise ParameterError(f"min contrast must be > 1, got {min_contrast}")
    dirs, omega, mask = env.texels()
    weights = env.quadrature_weights()
    px = env.pixels.astype(np.float64)
    lum = np.where(mask, px @ REC709_LUMINANCE, -np.inf)
    peak_idx = np.unravel_index(int(np.argmax(lum)), lum.shape)
    peak = float(lum[peak_idx])
    d0 = dirs[peak_idx]
    cap, background = _cap_and_background(dirs, mask, px, d0, radius_deg)
    bg_lum = float(background @ REC709_LUMINANCE)
    contrast = peak / max(bg_lum, 1e-12)
    report = {"peak_luminance": peak, "background": background, "contrast": contrast}
    if peak <= 0.0 or contrast < min_contrast:
        report["extracted"] = False
        return None, env, report
    total = env.total_energy(px)
    excess = _excess(px, cap, background)
    ex_lum = excess @ REC709_LUMINANCE
    gave = ex_lum > 0.0
    energy = np.einsum("hwc,hw->c", excess, weights)
    direction = np.einsum("hw,hwk->k", ex_lum * weights, dirs)
    direction /= np.linalg.norm(direction)
    solid_angle = float(omega[gave].sum())
    residual = env.pixels.astype(np.float32)  # L − 0 off the cap: the pixels themselves
    residual[cap] = px[cap] - excess[cap]
    sun = Sun(direction, solid_angle, energy / solid_angle)
    report.update(
        extracted=True,
        energy_fraction=energy / np.where(total > 0, total, 1.0),
        texels=int(gave.sum()),
    )
    return sun, Environment(residual, env.layout, dict(env.meta)), report
