"""Input policies for non-finite and negative pixels (SPEC §3).

Real HDR maps have negative pixels (lossy DWA compression rings around bright
lights: esplanade reaches −3894 next to its sun). NaN/Inf are refused unless
an explicit repair is asked for.
"""

import numpy as np

from shbake.errors import InputError, ParameterError
from shbake.messages import warn

NEGATIVE_POLICIES = ("clamp", "keep", "error")
DEFAULT_NEGATIVE = "clamp"
"""The policy when none is given (SPEC §3: clamp, with a warning)."""
NONFINITE_REPAIRS = ("black", "box3")


def repair_nonfinite(pixels: np.ndarray, repair: str | None, name: str) -> tuple[np.ndarray, int]:
    """Refuse (``repair=None``) or repair NaN/Inf pixels; return ``(pixels, count)``.

    ``black`` sets every non-finite channel value to 0; ``box3`` replaces it
    by the mean of the finite values among its 3×3 neighbours (0 if none).
    """
    # One pass when all are finite: NaN/Inf make the sum non-finite. It accumulates in
    # float64, where no sum of finite float32 values overflows (a float32 sum of texels near
    # 3.4e38 did: numpy warned, and the check below found nothing).
    if np.isfinite(pixels.sum(dtype=np.float64)):
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
        from scipy.ndimage import uniform_filter  # only --fix-nonfinite box3 needs it

        sums = uniform_filter(out.astype(np.float64), size=(3, 3, 1), mode="nearest")
        counts = uniform_filter(good, size=(3, 3, 1), mode="nearest")
        fill = np.divide(sums, counts, out=np.zeros_like(sums), where=counts > 1e-12)
        out = np.where(bad, fill, out).astype(np.float32)
    return out, count


def apply_negative_policy(
    pixels, weights, policy: str | None, name: str, quiet: bool = False, inplace: bool = False
):
    """Apply ``--negative clamp|keep|error``; return ``(pixels, count, energy_change)``.

    ``policy`` ``None`` (the option not given) clamps with a warning on stderr; an explicit
    ``clamp`` clamps without one (the user chose it; the count and the change are recorded
    in the asset either way).

    ``energy_change`` is ``Σ (new − old) · weight`` per channel (radiance ×
    sr): the change of ``∫ L dω`` caused by clamping. ``weights`` are the
    texel solid angles, shape ``(H, W)``. ``pixels`` must be finite; with
    ``inplace`` the clamp writes into ``pixels`` (the caller owns them) instead
    of a copy.
    """
    announce = policy is None
    policy = DEFAULT_NEGATIVE if policy is None else policy
    if policy not in NEGATIVE_POLICIES:
        raise ParameterError(f"unknown --negative {policy!r}; choose one of clamp, keep, error")
    nc = pixels.shape[2]
    change = np.zeros(nc)
    negative = pixels < 0  # one pass; everything after it touches only the (few) negatives
    if not negative.any():
        return pixels, 0, change
    flat_idx = np.flatnonzero(negative)  # C-order indices, as pixels.flat
    del negative
    texel = flat_idx // nc
    count = int(np.count_nonzero(np.diff(texel))) + 1  # flat_idx is sorted
    values = pixels.reshape(-1)[flat_idx].astype(np.float64)
    if policy == "keep":
        return pixels, count, change
    if policy == "error":
        raise InputError(
            f"{name}: {count} pixels are negative (min {float(values.min()):.6g}); "
            "use --negative clamp|keep"
        )
    w = pixels.shape[1]
    omega = np.asarray(weights)[texel // w, texel % w]  # (H, W) or a broadcast view of it
    change = -np.bincount(flat_idx % nc, weights=values * omega, minlength=nc)
    if announce:
        warn(f"{name}: clamped {count} negative pixels to 0 (min {float(values.min()):.6g}); "
             f"{_energy_change(pixels, weights, change)}; choose --negative clamp (no warning), "
             "keep or error", quiet)  # fmt: skip
    out = pixels if inplace else pixels.copy()
    out.flat[flat_idx] = 0.0  # the clamp writes the negatives only
    return out, count, change


ROWS_PER_SUM = 64
"""Rows of the map summed at a time in float64 (no float64 copy of a whole map)."""


def _energy_change(pixels, weights, change) -> str:
    """The clamp's change of ``∫ L dω`` per channel with its unit: in percent of the map's
    ``∫ L dω`` (before the clamp), or in the map's radiance × sr where that is not positive."""
    channels = "R, G, B" if change.size == 3 else "per channel"
    weights = np.asarray(weights)
    total = np.zeros(change.size)
    for r in range(0, pixels.shape[0], ROWS_PER_SUM):
        rows = slice(r, r + ROWS_PER_SUM)
        total += np.einsum("hwc,hw->c", pixels[rows], weights[rows], dtype=np.float64)
    if np.all(total > 0):
        shares = ", ".join(f"{v:+.3g} %" for v in 100.0 * change / total)
        return f"∫L dω ({channels}) changed by {shares} of the map's"
    values = ", ".join(f"{v:+.4g}" for v in change)
    return f"∫L dω ({channels}) changed by {values} (the map's radiance unit × sr)"
