"""The lat-long cell of a direction by table (:func:`shbake.envmap.layouts.latlong_cell_by_table`)
against :func:`~shbake.envmap.layouts.latlong_texel`'s ``acos`` and ``atan2``: wherever the
tables say they are sure, the very same cell, for random directions and for directions a
few ulps from every row and column edge, the poles and signed zeros; sure for nearly all
random directions; never sure on an edge.
"""

import numpy as np
import pytest

from shbake.envmap.layouts import latlong_cell_by_table, latlong_cells, latlong_texel
from shbake.jit import jit

SHAPES = [(2, 4), (3, 6), (5, 10), (8, 16), (64, 128), (256, 512), (1000, 2000)]


@jit(cache=False)
def _cells(d, height, width, cells, by_table, sure, exact):
    for i in range(d.shape[0]):
        r, c, s = latlong_cell_by_table(d[i, 0], d[i, 1], d[i, 2], height, width, cells)
        by_table[i] = r * width + c
        sure[i] = s
        exact[i] = latlong_texel(d[i, 0], d[i, 1], d[i, 2], height, width)


def _run(d, shape):
    by_table, exact = np.empty(len(d), np.int64), np.empty(len(d), np.int64)
    sure = np.empty(len(d), np.bool_)
    _cells(np.ascontiguousarray(d), *shape, latlong_cells(*shape), by_table, sure, exact)
    return by_table, sure, exact


def _unit(rng, n):
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _near_edges(rng, shape, n, ulps):
    """Directions at the row edges ``θ = π i/H`` and column edges ``φ = 2π j/W`` (and their
    crossings), each angle moved by up to ``ulps`` ulps."""
    h, w = shape
    theta = np.pi * rng.integers(0, h + 1, n) / h
    phi = 2.0 * np.pi * rng.integers(0, w + 1, n) / w
    free = rng.random(n) < 0.5  # half of them on one kind of edge only
    theta = np.where(free & (rng.random(n) < 0.5), rng.uniform(0, np.pi, n), theta)
    phi = np.where(free & (rng.random(n) >= 0.5), rng.uniform(0, 2 * np.pi, n), phi)
    theta = theta + rng.integers(-ulps, ulps + 1, n) * np.spacing(np.maximum(theta, 1e-300))
    phi = phi + rng.integers(-ulps, ulps + 1, n) * np.spacing(np.maximum(phi, 1e-300))
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], 1)


AXES = np.array(
    [
        [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
        [0.0, 1, -0.0], [-0.0, -1, 0.0], [-0.0, 0, 1], [0.0, 0, -1], [-0.0, 0, -1],
        [1, -0.0, 0], [1e-300, 1, 1e-300], [-1e-310, 0.5, -1e-310], [0.6, 0.0, -0.8],
        [0.6, 0.8, -0.0], [-0.6, 0.8, 0.0], [0, 1.0 + 2.0**-52, 0], [0, -1.0 - 2.0**-52, 0],
    ],
    dtype=np.float64,
)  # fmt: skip


@pytest.mark.parametrize("shape", SHAPES)
def test_sure_cells_are_latlong_texels(shape):
    rng = np.random.default_rng(shape[0])
    d = np.concatenate([_unit(rng, 100_000), _near_edges(rng, shape, 100_000, 4), AXES])
    by_table, sure, exact = _run(d, shape)
    np.testing.assert_array_equal(by_table[sure], exact[sure])
    assert np.all((by_table >= 0) & (by_table < shape[0] * shape[1]))  # in range when not sure
    assert sure[:100_000].mean() > 0.99  # random directions: the tables decide nearly all


@pytest.mark.parametrize("shape", [(8, 16), (256, 512)])
def test_never_sure_on_an_edge(shape):
    d = _near_edges(np.random.default_rng(1), shape, 20_000, 0)
    h, w = shape
    polar = np.arccos(np.clip(d[:, 1], -1, 1)) * h / np.pi
    az = np.arctan2(d[:, 0], -d[:, 2]) * w / (2.0 * np.pi)
    on_row, on_col = (np.abs(x - np.round(x)) < 1e-9 for x in (polar, az))
    assert on_row.sum() > 5000 and on_col.sum() > 5000
    _, sure, _ = _run(d, shape)
    assert not sure[on_row | on_col].any()
