"""Input policies for non-finite and negative pixels (SPEC §3).

Real HDR maps have negative pixels (lossy DWA compression rings around bright
lights: esplanade reaches −3894 next to its sun). NaN/Inf are refused unless
an explicit repair is asked for.
"""

import sys

import numpy as np
from scipy.ndimage import uniform_filter

from shbake.errors import InputError, ParameterError

NEGATIVE_POLICIES = ("clamp", "keep", "error")
NONFINITE_REPAIRS = ("black", "box3")


def repair_nonfinite(pixels: np.ndarray, repair: str | None, name: str) -> tuple[np.ndarray, int]:
    """Refuse (``repair=None``) or repair NaN/Inf pixels; return ``(pixels, count)``.

    ``black`` sets every non-finite channel value to 0; ``box3`` replaces it
    by the mean of the finite values among its 3×3 neighbours (0 if none).
    """
    if np.isfinite(pixels.sum(dtype=np.float64)):  # one pass when all are finite
        return pixels, 0
    bad = ~np.isfinite(pixels)
    count = int(np.any(bad, axis=2).sum())
    if count == 0:
        return pixels, 0
    if repair is None:
        raise InputError(
            f"{name}: {count} pixels are NaN or Inf; repair with --fix-nonfinite black|box3"
        )
    if repair not in NONFINITE_REPAIRS:
        raise ParameterError(f"unknown repair {repair!r}; choose one of black, box3")
    out = np.where(bad, 0.0, pixels).astype(np.float32)
    if repair == "box3":
        good = (~bad).astype(np.float64)
        sums = uniform_filter(out.astype(np.float64), size=(3, 3, 1), mode="nearest")
        counts = uniform_filter(good, size=(3, 3, 1), mode="nearest")
        fill = np.divide(sums, counts, out=np.zeros_like(sums), where=counts > 1e-12)
        out = np.where(bad, fill, out).astype(np.float32)
    return out, count


def apply_negative_policy(pixels, weights, policy: str, name: str, quiet: bool = False):
    """Apply ``--negative clamp|keep|error``; return ``(pixels, count, energy_change)``.

    ``energy_change`` is ``Σ (new − old) · weight`` per channel (radiance ×
    sr): the change of ``∫ L dω`` caused by clamping. ``weights`` are the
    texel solid angles, shape ``(H, W)``.
    """
    if policy not in NEGATIVE_POLICIES:
        raise ParameterError(f"unknown --negative {policy!r}; choose one of clamp, keep, error")
    change = np.zeros(pixels.shape[2])
    if pixels.size == 0 or pixels.min() >= 0:
        return pixels, 0, change
    neg = pixels < 0
    count = int(np.any(neg, axis=2).sum())
    if policy == "keep":
        return pixels, count, change
    if policy == "error":
        raise InputError(
            f"{name}: {count} pixels are negative (min {float(pixels.min()):.6g}); "
            "use --negative clamp|keep"
        )
    change = -np.einsum("hwc,hw->c", np.where(neg, pixels, 0.0).astype(np.float64), weights)
    if not quiet:
        print(
            f"shbake: warning: {name}: clamped {count} negative pixels to 0 "
            f"(min {float(pixels.min()):.6g}; ∫L dω change {np.array2string(change, precision=4)})",
            file=sys.stderr,
        )
    return np.maximum(pixels, 0.0), count, change
