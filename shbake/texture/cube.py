"""Cube maps in the OpenEXR ``envmap = cube`` convention (SPEC §3): addressing and bilinear fetch.

A cube map is an array ``(6, S, S, C)``: faces +X, −X, +Y, −Y, +Z, −Z in the
strip order of :data:`shbake.conventions.CUBE_FACES`, row ``i`` and
column ``j`` of a face at ``t = 2(i+½)/S − 1`` (top → bottom) and
``s = 2(j+½)/S − 1`` (left → right), direction ``∝ A_face @ (s, t, 1)``.
Texels are cells (GPU rule), the same geometry as the cube-strip input layout.

Addressing a direction ``d``: the face whose normal (third column of ``A``) has the
largest ``d · n_face`` — the largest ``|d_k|`` (ties: the first face in order) —,
``(s, t, 1) = A_faceᵀ d / (A_faceᵀ d)_z`` (``A`` is a signed permutation, so
``A⁻¹ = Aᵀ``), and continuous texel coordinates ``x = (s+1)S/2 − ½`` (column),
``y = (t+1)S/2 − ½`` (row). The same addressing serves any six faces given as
matrices, in any order (the GL/KTX faces of :mod:`shbake.bakers.cube_prefilter`).

Seam-correct bilinear fetch: the four taps around ``(x, y)`` are texel
centres of the face, extended past its border when ``(x, y)`` lies within
half a texel of an edge; a tap outside the face is turned back into a
direction and read from the face that holds it (a clamped bilinear fetch there). The
filtered value is continuous across edges and corners, as a GPU's seamless
cube filtering (``GL_TEXTURE_CUBE_MAP_SEAMLESS``); measured on a smooth
function: second-order inside faces and along edges, first-order only
within half a texel of the eight corners.
"""

import numpy as np

from shbake.conventions import CUBE_FACES, check_vectors
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.texture.bilinear import axis, blend

FACE_AXES = np.array([a for _, a in CUBE_FACES], dtype=np.float64)
"""``(6, 3, 3)`` face matrices (read-only)."""
FACE_AXES.flags.writeable = False


def cube_directions(size: int, axes: np.ndarray = FACE_AXES) -> np.ndarray:
    """Unit texel-centre directions ``(6, S, S, 3)`` of the faces ``axes`` (default: the
    cube-strip layout's, face by face).

    >>> cube_directions(1)[:, 0, 0].tolist()[0]  # the +X face's one texel
    [1.0, 0.0, 0.0]
    """
    if not isinstance(size, int | np.integer) or size < 1:
        raise ParameterError(f"cube face size must be a positive integer, got {size!r}")
    c = 2.0 * (np.arange(size) + 0.5) / size - 1.0
    s, t = np.meshgrid(c, c)  # s along columns, t along rows
    st1 = np.stack([s, t, np.ones_like(s)], axis=-1)
    d = np.einsum("fij,abj->fabi", axes, st1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


@jit
def cube_face_st(axes, dx, dy, dz):
    """Face and face coordinates ``(face, s, t)``, ``s, t ∈ [−1, 1]``, of a non-zero direction
    (faces ``axes``, ``(6, 3, 3)``; module docstring)."""
    best = -1.0
    face = 0
    for f in range(6):
        dn = dx * axes[f, 0, 2] + dy * axes[f, 1, 2] + dz * axes[f, 2, 2]
        if dn > best:
            best = dn
            face = f
    A = axes[face]
    u = A[0, 0] * dx + A[1, 0] * dy + A[2, 0] * dz
    w = A[0, 1] * dx + A[1, 1] * dy + A[2, 1] * dz
    return face, u / best, w / best


@jit
def texel_coordinate(s, size):
    """Continuous texel coordinate ``(s + 1) S/2 − ½`` of face coordinate ``s``, ``size`` texels."""
    return 0.5 * (s + 1.0) * size - 0.5


@jit
def cube_address(axes, dx, dy, dz, size):
    """Face and continuous texel coordinates ``(face, x, y)`` of a non-zero direction
    (faces ``axes``, ``(6, 3, 3)``; module docstring)."""
    face, s, t = cube_face_st(axes, dx, dy, dz)
    return face, texel_coordinate(s, size), texel_coordinate(t, size)


@jit
def _nearest_many(axes, dirs, size, face, row, col):
    for k in range(dirs.shape[0]):
        f, x, y = cube_address(axes, dirs[k, 0], dirs[k, 1], dirs[k, 2], size)
        face[k] = f
        col[k] = min(max(int(np.floor(x + 0.5)), 0), size - 1)
        row[k] = min(max(int(np.floor(y + 0.5)), 0), size - 1)


def nearest_texels(dirs, size: int, axes: np.ndarray = FACE_AXES):
    """``(face, row, column)`` int arrays of the texel holding each non-zero direction of
    ``dirs (..., 3)`` on faces of ``size`` texels (:func:`cube_address`, nearest centre).

    >>> [int(a[0]) for a in nearest_texels([[0.0, 0.0, -1.0]], 4)]  # −Z face, centre
    [5, 2, 2]
    """
    d = np.asarray(dirs, dtype=np.float64)
    flat = np.ascontiguousarray(d.reshape(-1, 3))
    out = [np.empty(flat.shape[0], dtype=np.int64) for _ in range(3)]
    _nearest_many(np.ascontiguousarray(axes, dtype=np.float64), flat, int(size), *out)
    return tuple(a.reshape(d.shape[:-1]) for a in out)


@jit
def face_bilinear(cube, face, x, y, c):
    """Bilinear fetch of channel ``c`` inside one face at continuous texel coordinates
    ``(x, y)`` (:func:`cube_address`), clamped to its texel centres (clamp-to-edge)."""
    size = cube.shape[1]
    i0, i1, fy = axis(y, size)
    j0, j1, fx = axis(x, size)
    return blend(cube[face, i0, j0, c], cube[face, i0, j1, c], cube[face, i1, j0, c],
                 cube[face, i1, j1, c], fy, fx)  # fmt: skip


@jit
def _beyond_border(axes, A, size, i, j):
    """Face and continuous texel coordinates of the direction of texel ``(i, j)`` of face
    ``A`` extended past its border: where a tap of :func:`cube_bilinear` outside the face
    is read."""
    s = 2.0 * (j + 0.5) / size - 1.0
    t = 2.0 * (i + 0.5) / size - 1.0
    ex = A[0, 0] * s + A[0, 1] * t + A[0, 2]
    ey = A[1, 0] * s + A[1, 1] * t + A[1, 2]
    ez = A[2, 0] * s + A[2, 1] * t + A[2, 2]
    return cube_address(axes, ex, ey, ez, size)


@jit
def cube_bilinear(cube, axes, dx, dy, dz, out):
    """``out[c]`` = seam-correct bilinear fetch of ``cube (6, S, S, C)`` at direction ``d``.

    A tap beyond the face border is the value at the direction of that
    (extended) texel centre, read by a clamped bilinear fetch on the face
    holding it: across an edge it falls on the neighbour's edge texels, so
    the fetch stays continuous and second-order accurate away from corners.
    """
    size = cube.shape[1]
    face, x, y = cube_address(axes, dx, dy, dz, size)
    j0 = int(np.floor(x))
    i0 = int(np.floor(y))
    fx, fy = x - j0, y - i0
    A = axes[face]
    for c in range(out.shape[0]):
        out[c] = 0.0
    for di in range(2):
        wy = fy if di == 1 else 1.0 - fy
        i = i0 + di
        for dj in range(2):
            wx = fx if dj == 1 else 1.0 - fx
            w = wx * wy
            if w == 0.0:
                continue
            j = j0 + dj
            if 0 <= i < size and 0 <= j < size:
                for c in range(out.shape[0]):
                    out[c] += w * cube[face, i, j, c]
                continue
            f2, x2, y2 = _beyond_border(axes, A, size, i, j)
            for c in range(out.shape[0]):
                out[c] += w * face_bilinear(cube, f2, x2, y2, c)


MAX_TAPS = 16
"""Most texels one :func:`cube_bilinear` fetch blends (four taps, each read bilinearly on the
face holding it when it lies past the border)."""


@jit
def cube_bilinear_taps(size, axes, dx, dy, dz, index, weight):
    """The texels and weights :func:`cube_bilinear` blends at direction ``d`` on faces of
    ``size`` texels: ``index[t] = (face · S + row) · S + column``, ``weight[t]`` (arrays of at
    least :data:`MAX_TAPS`); returns the number of taps. The same steps as
    :func:`cube_bilinear` (a tap past the border read bilinearly, clamped, on the face that
    holds its direction), as weights: what a least-squares fit of texel values to a
    bilinear read needs. Check-free kernel."""
    face, x, y = cube_address(axes, dx, dy, dz, size)
    j0 = int(np.floor(x))
    i0 = int(np.floor(y))
    fx, fy = x - j0, y - i0
    A = axes[face]
    n = 0
    for di in range(2):
        wy = fy if di == 1 else 1.0 - fy
        i = i0 + di
        for dj in range(2):
            wx = fx if dj == 1 else 1.0 - fx
            w = wx * wy
            if w == 0.0:
                continue
            j = j0 + dj
            if 0 <= i < size and 0 <= j < size:
                index[n] = (face * size + i) * size + j
                weight[n] = w
                n += 1
                continue
            f2, x2, y2 = _beyond_border(axes, A, size, i, j)
            r0, r1, gy = axis(y2, size)
            c0, c1, gx = axis(x2, size)
            for r, c, v in ((r0, c0, (1.0 - gy) * (1.0 - gx)), (r0, c1, (1.0 - gy) * gx),
                            (r1, c0, gy * (1.0 - gx)), (r1, c1, gy * gx)):  # fmt: skip
                index[n] = (f2 * size + r) * size + c
                weight[n] = w * v
                n += 1
    return n


LOOKUP_BLOCK = 1024
"""Directions per block of :func:`_sample_blocks` (the unit :func:`~shbake.jit.run_blocks`
hands to a thread)."""


@jit
def _sample_blocks(cube, axes, dirs, out, b0, b1):
    """:func:`cube_bilinear` at ``dirs[k]`` into ``out[k]`` for the directions of blocks
    ``b0 … b1-1``. Check-free kernel."""
    for k in range(b0 * LOOKUP_BLOCK, min(dirs.shape[0], b1 * LOOKUP_BLOCK)):
        cube_bilinear(cube, axes, dirs[k, 0], dirs[k, 1], dirs[k, 2], out[k])


def sample_cube(cube, dirs, axes: np.ndarray = FACE_AXES) -> np.ndarray:
    """Bilinear, seam-correct fetch of ``cube (6, S, S, C)`` at directions ``(..., 3)``
    (faces ``axes``, default the cube-strip layout's; any six signed permutations, e.g. the
    GL/KTX faces of :func:`shbake.format.exports.cube_chain.world_face_frames`).

    Returns ``dirs.shape[:-1] + (C,)`` float64. Directions need not be unit
    length but must be non-zero and finite.
    """
    c = np.asarray(cube, dtype=np.float64)
    if c.ndim != 4 or c.shape[0] != 6 or c.shape[1] != c.shape[2] or c.shape[1] < 1:
        raise ParameterError(f"a cube map has shape (6, S, S, C), got {c.shape}")
    d = check_vectors(dirs, "cube lookup directions")
    flat = np.ascontiguousarray(d.reshape(-1, 3))
    out = np.empty((flat.shape[0], c.shape[3]))
    n = flat.shape[0]
    run_blocks(_sample_blocks, -(-n // LOOKUP_BLOCK), n * 40.0 * c.shape[3],
               np.ascontiguousarray(c), np.ascontiguousarray(axes, dtype=np.float64), flat,
               out)  # fmt: skip
    return out.reshape(d.shape[:-1] + (c.shape[3],))
