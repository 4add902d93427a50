"""Turning an environment about the world's up axis (a scene probe's ``rotation_deg``).

A turn by ``θ`` degrees is counter-clockwise about +Y (world up, SPEC §2) seen
from above — the turn of ``shbake export --rotate``. With ``R = turn_matrix(θ)``
the turned environment shows at direction ``R d`` what the map shows at ``d``:
``L'(d) = L(Rᵀ d)``. SH coefficients turn as ``c' = M(R) c``
(:func:`shbake.sh.rotation.rotate`), exactly; a lat-long map turns by a
periodic shift of its columns (:func:`turn_latlong`), exact when ``θ`` is a
multiple of ``360° / W`` and linearly interpolated otherwise.
"""

import math

import numpy as np

from shbake.errors import ParameterError


def turn_matrix(deg: float, axis: int = 1) -> np.ndarray:
    """Rotation by ``deg`` degrees counter-clockwise about coordinate ``axis`` (1: +Y).

    ``axis`` 1 turns +Z toward +X (``(x, z) → (x cos θ + z sin θ, −x sin θ + z cos θ)``);
    in general the plane ``(axis+1, axis+2) mod 3`` turns by ``θ``, right-handed.
    """
    if not math.isfinite(deg):
        raise ParameterError(f"rotation must be finite, got {deg}")
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    T = np.eye(3)
    T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
    return T


def turn_latlong(pixels: np.ndarray, deg: float) -> np.ndarray:
    """A lat-long map ``(H, W, C)`` turned by ``deg`` about +Y: ``out(d) = in(Rᵀ d)``.

    In the lat-long layout (:func:`shbake.envmap.layouts.latlong_directions`,
    ``x = sin θ sin φ``, ``z = −sin θ cos φ``) the turn maps ``φ → φ − θ``, so
    column ``j`` of the result is the input at column ``j + θ W / 360`` (periodic,
    linear between the two nearest columns). Same dtype as ``pixels``.
    """
    w = pixels.shape[1]
    shift = (deg / 360.0 * w) % w
    k = int(math.floor(shift))
    f = shift - k
    if f > 1.0 - 1e-9:  # rounding of an exact multiple
        k, f = k + 1, 0.0
    a = np.roll(pixels, -k, axis=1)
    if f < 1e-9:
        return np.ascontiguousarray(a)
    b = np.roll(pixels, -k - 1, axis=1)
    return ((1.0 - f) * a.astype(np.float64) + f * b).astype(pixels.dtype)


def recorded_turn(asset) -> np.ndarray | None:
    """The turn ``R`` of the environment that an asset's pose records
    (``probe_rotation_deg``, a scene probe's; :func:`apply_pose`), ``None`` for none: what a
    reference of the map the asset records must see (the provenance block keeps the map
    unturned)."""
    deg = float(asset.attrs.get("probe_rotation_deg", 0.0))
    return None if deg % 360.0 == 0.0 else turn_matrix(deg)


def apply_pose(env, pose: dict, turn_pixels: bool = False):
    """Record a scene probe's ``pose`` (``{"position": [x, y, z], "rotation_deg": θ}``) in
    ``env.meta`` (``probe_position``, ``probe_rotation_deg``: the provenance block records
    them) and return the turn ``R`` for the SH (``None`` for no turn).

    ``turn_pixels``: turn the lat-long map itself (:func:`turn_latlong`) instead, for bakers
    that work on pixels; then ``None`` is returned. Other layouts cannot be turned by pixels.
    """
    deg = float(pose.get("rotation_deg", 0.0))
    env.meta["probe_position"] = np.asarray(pose.get("position", (0.0, 0.0, 0.0)), np.float64)
    env.meta["probe_rotation_deg"] = deg
    if deg % 360.0 == 0.0:
        return None
    if not turn_pixels:
        return turn_matrix(deg)
    if env.layout != "latlong":
        raise ParameterError(f"{env.meta.get('path', 'map')}: a probe's rotation_deg turns "
                             f"lat-long maps only, got {env.layout}")  # fmt: skip
    env.pixels = turn_latlong(env.pixels, deg)
    return None
