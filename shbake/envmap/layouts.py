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

from typing import NamedTuple

import numpy as np

from shbake.conventions import CUBE_FACES
from shbake.errors import LayoutError
from shbake.jit import jit
from shbake.simd import inline_into_callers

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


CELL_MARGIN = 1e-9
"""How far a direction must be from the edge :func:`latlong_cell_by_table` compares it
with (in ``cos θ`` from a row edge, in ``sin`` of the azimuth from a column edge) for the
comparison to decide; nearer, :func:`latlong_texel` decides. Its own rounding moves an
edge by under 1e-14 rad (``acos``, ``atan2`` within an ulp, then three roundings of
``u`` and ``v``), the tables' by under 1e-15: five orders of margin."""
CELL_SLOP = 1e-12
"""Widening of each bucket of :class:`LatlongCells` when its edge is chosen: ``1 − d_y``
and the pseudo-angle of :func:`latlong_cell_by_table` are rounded by under 1e-15, so a
direction that lands in a bucket is inside its widened range."""
ROW_BUCKETS, COL_BUCKETS = 8, 4
"""Buckets per row (over ``cos θ``) and per column (over the pseudo-angle) of
:class:`LatlongCells`. A column spans 3.1 to 6.3 buckets, a row at least two but within
``sin θ < 0.08`` of the poles (0.3 % of the sphere), where a bucket may hold two edges
and :func:`latlong_texel` decides."""


class LatlongCells(NamedTuple):
    """Tables of :func:`latlong_cell_by_table` for one lat-long shape (:func:`latlong_cells`).

    Per bucket of ``1 − d_y`` (``ROW_BUCKETS · H`` over ``[0, 2]``) the one row edge
    ``e`` its directions may lie on either side of, every other edge being more than
    :data:`CELL_MARGIN` away (``row_edge``; −1 where there is none: a bucket across two
    rows near a pole), and that edge's ``cos(π e/H)`` (``row_edge_y``); per bucket of the
    pseudo-angle (``COL_BUCKETS · W`` over ``[0, 4]``) the one column edge ``e``
    (``col_edge``) and its ``cos φ_e``, ``sin φ_e``, ``φ_e = 2π e/W`` (``col_edge_cos``,
    ``col_edge_sin``). Values per bucket, not per edge: the look-ups of one direction do
    not wait for each other.
    """

    row_edge: np.ndarray
    row_edge_y: np.ndarray
    col_edge: np.ndarray
    col_edge_cos: np.ndarray
    col_edge_sin: np.ndarray


def _bucket_edges(lo, hi, edges, stop):
    """For each ``[lo, hi]`` (increasing coordinate), the nearest of the increasing
    ``edges`` to its middle if every other edge is more than :data:`CELL_MARGIN` outside it,
    else −1; ``stop``: the coordinate's range, outside which there is no edge."""
    e = np.clip(np.searchsorted(edges, 0.5 * (lo + hi)), 1, edges.size - 1)
    e = np.where(0.5 * (lo + hi) - edges[e - 1] < edges[e] - 0.5 * (lo + hi), e - 1, e)
    below = np.where(e > 0, edges[np.maximum(e - 1, 0)], -stop)
    above = np.where(e < edges.size - 1, edges[np.minimum(e + 1, edges.size - 1)], 2 * stop)
    ok = (below + CELL_MARGIN < lo) & (hi < above - CELL_MARGIN)
    return np.where(ok, e, -1).astype(np.int32)


def latlong_cells(height: int, width: int) -> LatlongCells:
    """The tables of :func:`latlong_cell_by_table` for a ``width × height`` lat-long map:
    edges correctly rounded to within an ulp, each bucket's edge chosen over its range
    widened by :data:`CELL_SLOP` (then turned into ``θ`` for rows, ``φ`` for columns)."""
    theta_edges = np.pi * np.arange(height + 1) / height
    rows = ROW_BUCKETS * height
    y = np.clip(2.0 * np.arange(rows + 1) / rows + np.array([[-CELL_SLOP], [CELL_SLOP]]), 0, 2)
    theta = np.arccos(1.0 - y)  # bucket i: 1 − d_y in [y[0, i], y[1, i + 1]]
    row_edge = _bucket_edges(theta[0, :-1], theta[1, 1:], theta_edges, np.pi)
    phi_edges = 2.0 * np.pi * np.arange(width + 1) / width
    cols = COL_BUCKETS * width
    p = np.clip(4.0 * np.arange(cols + 1) / cols + np.array([[-CELL_SLOP], [CELL_SLOP]]), 0, 4)
    t = np.where(p < 2.0, 1.0 - p, p - 3.0)  # the inverse of the pseudo-angle
    phi = np.where(p < 2.0, np.arctan2(1.0 - np.abs(t), t),
                   2.0 * np.pi + np.arctan2(np.abs(t) - 1.0, t))  # fmt: skip
    col_edge = _bucket_edges(phi[0, :-1], phi[1, 1:], phi_edges, 2.0 * np.pi)
    rb, cb = np.maximum(row_edge, 0), np.maximum(col_edge, 0)
    return LatlongCells(row_edge, np.cos(theta_edges)[rb], col_edge, np.cos(phi_edges)[cb],
                        np.sin(phi_edges)[cb])  # fmt: skip


@jit
def latlong_cell_by_table(dx, dy, dz, height, width, cells):
    """``(row, col, sure)``: the lat-long cell of world direction ``d`` found with the
    tables, and whether it is proven to be :func:`latlong_texel`'s (``row * W + col``).
    Branch-free, so that a loop over directions vectorises; inlined into its callers
    (passing the tables to a call would count references). Row and column are in range
    when not sure.

    The row: bucket ``1 − d_y`` (:class:`LatlongCells`); of the two rows beside the
    bucket's edge ``cos(π e/H)``, the one on ``d_y``'s side. The column: bucket the
    pseudo-angle ``p = 1 − b/(|a|+|b|)`` (``a ≥ 0``) or ``3 + b/(|a|+|b|)``,
    ``(a, b) = (d_x, −d_z)``, which increases with the azimuth ``φ = atan2(a, b)`` over
    ``[0, 2π]``; of the two columns beside the bucket's edge ``φ_e``, the one on the side
    given by the sign of ``cos φ_e a − sin φ_e b = |(a, b)| sin(φ − φ_e)``.
    Every other edge being farther than :data:`CELL_MARGIN` from the bucket, the cell is
    sure when both comparisons clear that margin (and ``|a| + |b|`` is not denormal).
    """
    inline_into_callers()
    rows, cols = cells.row_edge.shape[0], cells.col_edge.shape[0]
    i = min(max(int((1.0 - dy) * (0.5 * rows)), 0), rows - 1)
    er, top = cells.row_edge[i], cells.row_edge_y[i]
    r = er - (dy > top)
    a, b = dx, -dz
    s = abs(a) + abs(b)
    t = b / max(s, 1e-300)
    p = 1.0 - t if a >= 0.0 else 3.0 + t
    i = min(max(int(p * (0.25 * cols)), 0), cols - 1)
    ec = cells.col_edge[i]
    x = cells.col_edge_cos[i] * a - cells.col_edge_sin[i] * b
    c = min(max(ec - (x <= 0.0), 0), width - 1)  # bucket 0 starts at φ = 0, the last ends at 2π
    sure = ((er >= 0) & (ec >= 0) & (r >= 0) & (r < height) & (abs(dy - top) > CELL_MARGIN)
            & (s > 1e-150) & (abs(x) > CELL_MARGIN * s))  # fmt: skip
    return min(max(r, 0), height - 1), c, sure


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


def cube_face_solid_angles(n: int) -> np.ndarray:
    """Exact solid angle of each texel of an ``n``² cube face, ``(n, n)`` (the same grid on
    every face; sums to 4π/6)."""
    edges = 2.0 * np.arange(n + 1) / n - 1.0
    return np.abs(
        _face_area(edges[None, 1:], edges[1:, None])
        - _face_area(edges[None, :-1], edges[1:, None])
        - _face_area(edges[None, 1:], edges[:-1, None])
        + _face_area(edges[None, :-1], edges[:-1, None])
    )


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
    area = cube_face_solid_angles(n)
    dirs = np.zeros((height, width, 3))
    omega = np.zeros((height, width))
    mask = np.zeros((height, width), dtype=bool)
    st1 = np.stack([s, t, np.ones_like(s)], axis=-1)
    for col, row, A in cells:
        d = st1 @ np.asarray(A, dtype=np.float64).T
        rs, cs = slice(row * n, (row + 1) * n), slice(col * n, (col + 1) * n)
        dirs[rs, cs] = d / np.linalg.norm(d, axis=-1, keepdims=True)
        omega[rs, cs] = area
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
