"""An environment map loaded, validated and ready to integrate."""

import contextlib
import functools
import os

import numpy as np

from shbake.envmap.colorspace import WORKING_SPACE, to_working_space
from shbake.envmap.image_io import read_image, sha256_of, to_rgb
from shbake.envmap.layouts import (
    check_layout,
    detect_layout,
    latlong_row_solid_angles,
    texels,
)
from shbake.envmap.repair import DEFAULT_NEGATIVE, apply_negative_policy, repair_nonfinite
from shbake.errors import ImageReadError
from shbake.messages import warn
from shbake.resources import file_identity, path_arguments
from shbake.sh.projection import fejer_row_weights, project_latlong, project_samples


class Environment:
    """Radiance on the sphere, stored as an image of a known layout.

    Attributes
    ----------
    pixels : (H, W, 3) float32
        Linear Rec.709 radiance, finite.
    layout : str
        One of ``shbake.envmap.LAYOUTS``.
    meta : dict
        Provenance and input-policy record (path, SHA-256, counts).
    """

    __slots__ = ("pixels", "layout", "meta")

    def __init__(self, pixels: np.ndarray, layout: str, meta: dict | None = None):
        self.pixels = pixels
        self.layout = layout
        self.meta = {} if meta is None else meta

    def __repr__(self) -> str:
        return f"Environment({self.layout!r}, {self.pixels.shape})"

    @property
    def shape(self) -> tuple[int, int]:
        return self.pixels.shape[0], self.pixels.shape[1]

    def texels(self):
        """``(dirs (H,W,3), solid_angles (H,W), mask (H,W))`` — exact cell geometry, read-only
        (:func:`texel_geometry`: built once per layout and shape)."""
        return texel_geometry(self.layout, *self.shape)

    def quadrature_weights(self) -> np.ndarray:
        """Weights the projection uses, ``(H, W)``: Fejér for lat-long, solid angles for cubes
        (read-only, :func:`quadrature_weights`)."""
        return quadrature_weights(self.layout, *self.shape)

    def samples(self):
        """Valid texels as flat arrays ``(dirs (N,3), solid_angles (N,), radiance (N,3))``."""
        dirs, omega, mask = self.texels()
        return dirs[mask], omega[mask], self.pixels[mask].astype(np.float64)

    def project(self, lmax: int) -> np.ndarray:
        """SH lighting coefficients ``L_lm`` in the world frame, ``((lmax+1)^2, 3)``."""
        if self.layout == "latlong":
            return project_latlong(self.pixels, lmax)
        dirs, omega, mask = self.texels()
        return project_samples(dirs[mask], omega[mask], self.pixels[mask], lmax)

    def total_energy(self, pixels64: np.ndarray | None = None) -> np.ndarray:
        """``∫ L dω`` per channel with the projection's weights (radiance × sr); ``pixels64``:
        the pixels as float64 when the caller has them (no second copy)."""
        px = self.pixels.astype(np.float64) if pixels64 is None else pixels64
        return np.einsum("hwc,hw->c", px, self.quadrature_weights())


GEOMETRY_SHAPES = 4
"""Layouts and shapes whose texel geometry and weights a process keeps
(:func:`texel_geometry`, :func:`quadrature_weights`)."""
GEOMETRY_KEPT_TEXELS = 1 << 21
"""Largest map (texels) whose geometry is kept: ~70 MB of directions, solid angles and
mask (a 2048 × 1024 lat-long map); a larger map's is built on each call, so that what a
process keeps stays bounded whatever maps it reads."""


def _read_only(*arrays):
    for a in arrays:
        a.flags.writeable = False
    return arrays


def _kept_when_small(build):
    """``build(layout, height, width)`` once per process and shape (at most
    :data:`GEOMETRY_SHAPES` kept) for maps of up to :data:`GEOMETRY_KEPT_TEXELS` texels; on
    every call for larger ones."""
    kept = functools.lru_cache(maxsize=GEOMETRY_SHAPES)(build)

    @functools.wraps(build)
    def get(layout: str, height: int, width: int):
        return (kept if height * width <= GEOMETRY_KEPT_TEXELS else build)(layout, height, width)

    return get


@_kept_when_small
def texel_geometry(layout: str, height: int, width: int):
    """:func:`~shbake.envmap.layouts.texels` of ``layout`` and shape: ``(dirs (H,W,3),
    solid_angles (H,W), mask (H,W))``, read-only (shared by every map of that shape)."""
    return _read_only(*texels(layout, height, width))


@_kept_when_small
def quadrature_weights(layout: str, height: int, width: int) -> np.ndarray:
    """The projection's weight of every texel, ``(H, W)``, read-only: Fejér row weights
    (:func:`~shbake.sh.projection.fejer_row_weights`) for lat-long, the exact solid angles
    for cube layouts."""
    if layout == "latlong":
        return _read_only(np.repeat(fejer_row_weights(height, width)[:, None], width, axis=1))[0]
    return texel_geometry(layout, height, width)[1]


DECODED_LIMIT = 8
"""Most maps a :func:`decoded_once` scope keeps (a chunk of a scene's maps)."""
_decoded: dict | None = None


@contextlib.contextmanager
def decoded_once():
    """Within the block, :func:`load_environment` decodes each file once: a later call with
    the same file (path, inode, size and modification time unchanged) and the same policies
    gets a copy of the first call's result (its own pixels, no warning printed again) — so
    a scene's assets of one map and their checks share one decode. At most
    :data:`DECODED_LIMIT` maps are kept (the oldest dropped); nothing outlives the block."""
    global _decoded
    outer, _decoded = _decoded, {}
    try:
        yield
    finally:
        _decoded = outer


def _decode_key(path, *policies):
    identity = file_identity(path)
    if identity is None:
        return None  # the decode says what is wrong
    return (os.path.abspath(path), *identity, *policies)


@path_arguments("path")
def load_environment(
    path: str,
    layout: str | None = None,
    colorspace: str | None = None,
    negative: str | None = None,
    fix_nonfinite: str | None = None,
    quiet: bool = False,
) -> Environment:
    """Read, validate and convert an environment map.

    Order of operations: read → RGB → layout → non-finite policy → colourspace
    → negative policy (``None``: clamp with a warning). See :mod:`shbake.envmap.repair`
    for the policies.
    """
    key = None
    if _decoded is not None:  # policies as applied: None is the default of each
        key = _decode_key(path, colorspace, negative or DEFAULT_NEGATIVE, fix_nonfinite)
    first = _decoded.get(key) if key is not None else None
    if first is not None and layout in (None, first.layout):  # detection: the same layout
        return Environment(first.pixels.copy(), first.layout, dict(first.meta))
    env = _load_environment(path, layout, colorspace, negative, fix_nonfinite, quiet)
    if key is not None and key not in _decoded:
        if len(_decoded) >= DECODED_LIMIT:
            del _decoded[next(iter(_decoded))]
        _decoded[key] = Environment(env.pixels.copy(), env.layout, dict(env.meta))
    return env


def _load_environment(path, layout, colorspace, negative, fix_nonfinite, quiet) -> Environment:
    identity = file_identity(path)  # the pixels, the hash and the size are three reads
    raw, info = read_image(path)
    if info.get("display_referred") and colorspace is None:
        warn(f"{path}: {info['format']} pixels are display-referred, read as linear radiance; "
             "give --colorspace sRGB-display to decode sRGB", quiet)  # fmt: skip
    rgb, channel_note = to_rgb(raw, info["channelnames"])
    h, w = rgb.shape[:2]
    layout = check_layout(layout, h, w) if layout else detect_layout(h, w, info["envmap"])
    rgb, nonfinite = repair_nonfinite(rgb, fix_nonfinite, path)
    if colorspace:
        rgb = to_working_space(rgb, colorspace, path)
    if layout == "latlong":  # every texel is valid; one solid angle per row
        omega = np.broadcast_to(latlong_row_solid_angles(h, w)[:, None], (h, w))
        rgb = rgb.astype(np.float32, copy=False)
    else:
        _, omega, mask = texels(layout, h, w)
        rgb = np.where(mask[:, :, None], rgb, 0.0).astype(np.float32)
    # rgb is this function's own (decoded here): clamp in place
    rgb, n_negative, energy_change = apply_negative_policy(
        rgb, omega, negative, path, quiet, inplace=True
    )
    digest = sha256_of(path)
    if file_identity(path) != identity:
        raise ImageReadError(f"{path}: changed while it was read; run again once it is written")
    meta = {
        "path": str(path),
        "sha256": digest,
        "size": identity[1],
        "width": w,
        "height": h,
        "layout": layout,
        "stored_format": info["format"],
        "channels": channel_note,
        "colorspace_in": colorspace or WORKING_SPACE,
        "colorspace": WORKING_SPACE,
        "nonfinite_policy": fix_nonfinite or "error",
        "nonfinite_repaired": nonfinite,
        "negative_policy": negative or DEFAULT_NEGATIVE,
        "negative_count": n_negative,
        "negative_energy_change": energy_change,
    }
    return Environment(np.ascontiguousarray(rgb, dtype=np.float32), layout, meta)
