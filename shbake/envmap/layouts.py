"""Image layouts of environment maps: texel directions and exact solid angles (SPEC §3).

``latlong``
    OpenEXR ``envmap = latlong``: row 0 = +Y, image centre = +Z, ``u = 0.25``
    = +X, edges = −Z; ``u = atan2(d.x, -d.z)/(2π) mod 1``, ``v = acos(d.y)/π``.
``cube-strip``
    OpenEXR ``envmap = cube``: six square faces +X, −X, +Y, −Y, +Z, −Z stacked
    vertically (W × 6W), with OpenEXR's per-face orientation.
``cross-h`` / ``cross-v``
    Horizontal (4:3) and vertical (3:4) crosses, unfolded as seen from inside
    with +Y up: the middle row is the panorama ``+X, +Z, −X`` (``, −Z`` for the
    horizontal cross), +Y above +Z, −Y below; the vertical cross puts −Z below
    −Y, upside down. Unused cells are ignored.

Every texel is a cell; its direction is the cell centre and its weight the
exact solid angle of the cell (for cube faces: the area of the projected
texel, ``F(s,t) = atan2(st, sqrt(s²+t²+1))`` differenced over the corners).
OpenEXR's own ``CubeMap::direction`` maps the *centres* of edge texels to the
cube edges; shbake uses the texel-cell rule of GPUs instead (half a texel
apart).
"""

import numpy as np

from shbake.conventions import CUBE_FACES
from shbake.errors import LayoutError
from shbake.jit import jit

LAYOUTS = ("latlong", "cube-strip", "cross-h", "cross-v")

# Per face: direction = A @ (s, t, 1), s = left→right, t = top→bottom in [-1, 1].
_STRIP_FACES = dict(CUBE_FACES)  # the one table of face orientations (shbake.conventions)
_CROSS_POLES = {
    "+Y": ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
    "-Y": ((-1, 0, 0), (0, 0, -1), (0, -1, 0)),
    "-Z_down": ((-1, 0, 0), (0, 1, 0), (0, 0, -1)),
}
# (layout) -> (cells wide, cells high, [(col, row, A)])
_CELLS = {
    "cube-strip": (1, 6, [(0, k, _STRIP_FACES[f]) for k, f in enumerate(_STRIP_FACES)]),
    "cross-h": (
        4,
        3,
        [
            (0, 1, _STRIP_FACES["+X"]),
            (1, 1, _STRIP_FACES["+Z"]),
            (2, 1, _STRIP_FACES["-X"]),
            (3, 1, _STRIP_FACES["-Z"]),
            (1, 0, _CROSS_POLES["+Y"]),
            (1, 2, _CROSS_POLES["-Y"]),
        ],
    ),
    "cross-v": (
        3,
        4,
        [
            (0, 1, _STRIP_FACES["+X"]),
            (1, 1, _STRIP_FACES["+Z"]),
            (2, 1, _STRIP_FACES["-X"]),
            (1, 0, _CROSS_POLES["+Y"]),
            (1, 2, _CROSS_POLES["-Y"]),
            (1, 3, _CROSS_POLES["-Z_down"]),
        ],
    ),
}


def fits_layout(layout: str, height: int, width: int) -> bool:
    """Whether a ``width × height`` image has ``layout``'s shape (the one rule detection and
    ``--layout`` share)."""
    return {
        "latlong": width == 2 * height and height >= 2,
        "cube-strip": height == 6 * width and width >= 1,
        "cross-h": 3 * width == 4 * height and width % 4 == 0 and width >= 4,
        "cross-v": 4 * width == 3 * height and width % 3 == 0 and width >= 3,
    }[layout]


def detect_layout(height: int, width: int, envmap_attr: str | None = None) -> str:
    """Layout from the image shape (and OpenEXR's ``envmap`` attribute if present): the
    first of :data:`LAYOUTS` whose shape fits (:func:`fits_layout`), so that a detected
    layout is always one ``--layout`` accepts."""
    if envmap_attr == "cube" and fits_layout("cube-strip", height, width):
        return "cube-strip"
    for layout in ("latlong", "cube-strip", "cross-h", "cross-v"):
        if fits_layout(layout, height, width):
            return layout
    raise LayoutError(
        f"cannot tell the layout of a {width}x{height} image: expected 2:1 lat-long of at "
        "least 2 rows, 1:6 cube strip, 4:3 or 3:4 cross (or give --layout)"
    )


def check_layout(layout: str, height: int, width: int) -> str:
    """Validate that ``layout`` fits a ``width × height`` image."""
    if layout not in LAYOUTS:
        raise LayoutError(f"unknown layout {layout!r}; choose one of {', '.join(LAYOUTS)}")
    if not fits_layout(layout, height, width):
        raise LayoutError(f"a {width}x{height} image does not have the {layout} layout's shape")
    return layout


def latlong_directions(height: int, width: int) -> np.ndarray:
    """World directions of lat-long cell centres, ``(H, W, 3)``."""
    theta = np.pi * (np.arange(height) + 0.5) / height
    phi = 2.0 * np.pi * (np.arange(width) + 0.5) / width
    st = np.sin(theta)[:, None]
    return np.stack(
        [
            st * np.sin(phi)[None, :],
            np.repeat(np.cos(theta)[:, None], width, 1),
            -st * np.cos(phi)[None, :],
        ],
        axis=-1,
    )


@jit
def row_solid_angle(row, height, width):
    """Exact solid angle of one cell of lat-long row ``row`` (sr):
    ``(2π/W)(cos(π i/H) − cos(π(i+1)/H))`` (SPEC §3)."""
    return (np.cos(np.pi * row / height) - np.cos(np.pi * (row + 1) / height)) * 2.0 * np.pi / width


@jit
def log2_row_solid_angles(height, width):
    """``log2`` of :func:`row_solid_angle` for every row, ``(H,)``: the level-0 texel size
    filtered importance sampling compares a sample's solid angle with (Křivánek & Colbert
    2008), in the kernels that pick a pyramid level per sample."""
    out = np.empty(height)
    for row in range(height):
        out[row] = np.log2(row_solid_angle(row, height, width))
    return out


def latlong_row_solid_angles(height: int, width: int) -> np.ndarray:
    """Exact solid angle of one cell of each lat-long row, ``(H,)`` (:func:`row_solid_angle`).

    Evaluated by the kernel's Python function on all rows at once (numpy):
    the same formula, and no numba load for a small bake.
    """
    return row_solid_angle.py_func(np.arange(height, dtype=np.float64), height, width)


def latlong_solid_angles(height: int, width: int) -> np.ndarray:
    """Exact solid angle of every lat-long cell, ``(H, W)``; sums to 4π."""
    return np.repeat(latlong_row_solid_angles(height, width)[:, None], width, axis=1)


@jit
def latlong_texel(dx, dy, dz, height, width):
    """Flat index ``row * W + col`` of the lat-long cell holding world direction ``d`` (SPEC §3)."""
    u = np.arctan2(dx, -dz) / (2.0 * np.pi)
    if u < 0.0:
        u += 1.0
    v = np.arccos(min(1.0, max(-1.0, dy))) / np.pi
    col = min(int(u * width), width - 1)
    row = min(int(v * height), height - 1)
    return row * width + col


@jit
def latlong_texel_point(j, f, u, height, width):
    """A point of lat-long cell ``j`` (flat index): ``f`` ∈ [0, 1] uniform in ``cos θ`` across
    the row, ``u`` ∈ [0, 1] across the column (SPEC §3); ``f = u = ½`` is the cell centre in
    solid angle."""
    row, col = j // width, j % width
    z0, z1 = np.cos(np.pi * row / height), np.cos(np.pi * (row + 1) / height)
    y = z0 - f * (z0 - z1)
    s = np.sqrt(max(0.0, 1.0 - y * y))
    phi = 2.0 * np.pi * (col + u) / width
    return s * np.sin(phi), y, -s * np.cos(phi)


def cube_face_frames() -> np.ndarray:
    """``(6, 3, 3)`` frames of the cube-strip faces (+X, −X, +Y, −Y, +Z, −Z).

    ``frames[f] @ (s, t, 1)`` is the (unnormalised) direction of face ``f`` at
    face coordinates ``s`` (left → right) and ``t`` (top → bottom) in [-1, 1];
    the columns are orthonormal (s axis, t axis, face normal).
    """
    return np.array([_STRIP_FACES[f] for f in _STRIP_FACES], dtype=np.float64)


def _face_area(x, y):
    return np.arctan2(x * y, np.sqrt(x * x + y * y + 1.0))


def cube_texels(layout: str, height: int, width: int):
    """Directions ``(H, W, 3)``, solid angles ``(H, W)`` and a validity mask of a cube layout.

    Cells outside the six faces (crosses) have direction 0, solid angle 0 and
    mask ``False``.
    """
    cw, ch, cells = _CELLS[layout]
    n = width // cw
    edges = 2.0 * np.arange(n + 1) / n - 1.0
    centres = 0.5 * (edges[:-1] + edges[1:])
    s, t = np.meshgrid(centres, centres)  # s varies along columns, t along rows
    area = (
        _face_area(edges[None, 1:], edges[1:, None])
        - _face_area(edges[None, :-1], edges[1:, None])
        - _face_area(edges[None, 1:], edges[:-1, None])
        + _face_area(edges[None, :-1], edges[:-1, None])
    )
    dirs = np.zeros((height, width, 3))
    omega = np.zeros((height, width))
    mask = np.zeros((height, width), dtype=bool)
    st1 = np.stack([s, t, np.ones_like(s)], axis=-1)
    for col, row, A in cells:
        d = st1 @ np.asarray(A, dtype=np.float64).T
        rs, cs = slice(row * n, (row + 1) * n), slice(col * n, (col + 1) * n)
        dirs[rs, cs] = d / np.linalg.norm(d, axis=-1, keepdims=True)
        omega[rs, cs] = np.abs(area)
        mask[rs, cs] = True
    return dirs, omega, mask


def texels(layout: str, height: int, width: int):
    """Directions, exact solid angles and validity mask of any layout."""
    if layout == "latlong":
        return (
            latlong_directions(height, width),
            latlong_solid_angles(height, width),
            np.ones((height, width), dtype=bool),
        )
    return cube_texels(layout, height, width)
