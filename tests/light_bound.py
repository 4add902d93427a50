"""The branch-and-bound lower bound on what a few lights + 9 SH coefficients can give a
diffuse probe, shared by ``bench/irradiance_bound.py`` (the argument, and issue 33's run on
the shared maps) and ``tests/system/test_light_bound.py`` (its checks).

A light is ``max(0, n·v + t)`` (``v = s d``, ``t = s f``; ``f`` 0 for a directional light, a
rectangle's form factor for three.js's ``RectAreaLight``); its direction is bounded to a
cell of a cube face, ``τ = t / (v·a)`` to an interval; :class:`Relaxation` is the linear
programme whose least mean relative error no lights in those cells beat, and
:func:`branch_and_bound` splits cells until every cell tuple is discarded (a proof that
none meets the limits) or one is finer than ``max_level``.
"""

import itertools
import multiprocessing
import time

import numpy as np

SOLVER_MARGIN = 1e-5
"""Added to both limits before a triple is discarded (the solver's tolerances are 1e-7)."""
SUBSET_STRIDE = 8
"""Every eighth normal: the cheap infeasibility test tried first."""
MAX_LEVEL = 12
"""A cell finer than this (about 0.02°) left undiscarded stops the search: a fit may exist."""
TAU_MAX = float(np.sqrt(3.0))


def _faces(count: int) -> list:
    e = np.eye(3)
    axes = [(e[i], e[(i + 1) % 3], e[(i + 2) % 3]) for i in range(3)]
    return axes if count == 3 else axes + [(-a, u, v) for a, u, v in axes]


class Relaxation:
    """The linear programme of one cell triple at ``normals`` (brute-force luminance
    irradiance ``ref`` there), its mean taken over ``total`` normals."""

    def __init__(self, normals, ref, total, faces):
        from shbake.sh.basis import real_sh

        self.n, self.E, self.total, self.faces = normals, ref, total, faces
        self.Y = real_sh(normals, 2) / ref[:, None]

    def light(self, cell):
        """``(positive, band, planes, cone)``: the normals whose term is ``n·v + t`` over the
        cell, those whose term changes sign and the upper planes there (``(nb, P, 4)``,
        linear in ``(v, t)``), and the cell's cone rows (``rows · (v, t) ≥ 0``)."""
        face, level, i, j, tl, k = cell
        a, eu, ev = self.faces[face]
        h = 2.0 / (1 << level)
        x0, y0 = -1.0 + i * h, -1.0 + j * h
        xs, ys = np.array([x0, x0 + h, x0 + h, x0]), np.array([y0, y0, y0 + h, y0 + h])
        width = TAU_MAX / (1 << tl) if tl >= 0 else 0.0
        tau_lo, tau_hi = (k * width, (k + 1) * width) if tl >= 0 else (0.0, 0.0)
        corners = a + xs[:, None] * eu + ys[:, None] * ev
        g = self.n @ corners.T
        positive = (g + tau_lo > 0).all(1)
        band = np.flatnonzero(~positive & ~(g + tau_hi <= 0).all(1))
        planes = []
        for tau, slope in ((tau_hi, 0.0), (tau_lo, 1.0)) if tau_hi > tau_lo else ((tau_lo, 0.0),):
            G = np.maximum(g[band] + tau, 0.0)
            d13 = G[:, 0] + G[:, 2] >= G[:, 1] + G[:, 3]  # the upper diagonal
            for tri13, tri24 in (([0, 1, 2], [0, 1, 3]), ([0, 2, 3], [1, 2, 3])):
                idx = np.where(d13[:, None], tri13, tri24)
                X = np.stack([np.ones(idx.shape), xs[idx], ys[idx]], -1)
                p = np.linalg.solve(X, np.take_along_axis(G, idx, 1)[..., None])[..., 0]
                # p0 + p1 x + p2 y + slope (τ − τ_lo), times w = v·a: linear in (v, t)
                vec = (p[:, :1] - slope * tau_lo) * a + p[:, 1:2] * eu + p[:, 2:3] * ev
                planes.append(np.hstack([vec, np.full((len(band), 1), slope)]))
        cone = [np.append(eu - x0 * a, 0), np.append((x0 + h) * a - eu, 0),
                np.append(ev - y0 * a, 0), np.append((y0 + h) * a - ev, 0),
                np.append(-tau_lo * a, 1.0), np.append(tau_hi * a, -1.0)]  # fmt: skip
        return positive, band, np.stack(planes, 1), np.array(cone)

    def lower(self, cells, cap: float, method: str = "highs-ipm", presolve: bool = False) -> float:
        """The least mean error (over :attr:`total` normals) of any lights in ``cells``
        with every error ≤ ``cap``; ``inf`` when none keeps every error within it
        (``method``: HiGHS's interior point, the fastest here on all normals, or its dual
        simplex, on a few; ``presolve``: HiGHS's reductions first)."""
        from scipy import sparse
        from scipy.optimize import linprog

        N, k = len(self.E), len(cells)
        terms = [self.light(c) for c in cells]
        nb = [len(t[1]) for t in terms]
        col_w = 9 + 4 * k
        col_u = col_w + N + np.concatenate([[0], np.cumsum(nb)])
        nv = col_u[-1]
        nT = np.hstack([self.n, np.ones((N, 1))]) / self.E[:, None]
        dense = np.hstack([self.Y, *[nT * t[0][:, None] for t in terms]])
        u_rows = np.concatenate([t[1] for t in terms])
        model = sparse.hstack([sparse.csr_matrix(dense), sparse.csr_matrix((N, nv - col_w))])
        model = model.tocsr() + sparse.csr_matrix(
            (1.0 / self.E[u_rows], (u_rows, np.arange(col_u[0], nv))), shape=(N, nv)
        )
        W = sparse.csr_matrix((np.ones(N), (np.arange(N), col_w + np.arange(N))), (N, nv))
        rows, rhs = [model - W, -model - W], [np.ones(N), -np.ones(N)]
        for q, (_, band, planes, cone) in enumerate(terms):
            vt = 9 + 4 * q + np.arange(4)
            m = len(band)
            if m:  # n·v + t − u ≤ 0 and u − plane·(v, t) ≤ 0
                lin = [np.hstack([self.n[band], np.ones((m, 1))])] + [
                    -planes[:, p] for p in range(planes.shape[1])
                ]
                blocks = len(lin)
                vals = np.concatenate(
                    [x.ravel() for x in lin] + [np.full(m, -1.0)] + [np.ones(m)] * (blocks - 1)
                )
                r = np.arange(blocks * m)
                rr = np.concatenate([np.repeat(r, 4), r])
                cc = np.concatenate(
                    [np.tile(vt, blocks * m), np.tile(col_u[q] + np.arange(m), blocks)]
                )
                rows.append(sparse.csr_matrix((vals, (rr, cc)), (blocks * m, nv)))
                rhs.append(np.zeros(blocks * m))
            C = np.zeros((len(cone), nv))
            C[:, vt] = -cone
            rows.append(sparse.csr_matrix(C))
            rhs.append(np.zeros(len(cone)))
        cost = np.zeros(nv)
        cost[col_w : col_w + N] = 1.0 / self.total
        bounds = [(None, None)] * col_w + [(0, cap)] * N + [(0, None)] * (nv - col_u[0])
        res = linprog(
            cost,
            A_ub=sparse.vstack(rows).tocsr(),
            b_ub=np.concatenate(rhs),
            bounds=bounds,
            method=method,
            options={"presolve": presolve},
        )
        if res.status == 2:
            return np.inf
        if not res.success:
            raise RuntimeError(f"{cells}: {res.message}")
        return float(res.fun)


def _roots(family: str) -> list:
    if family == "directional":
        return [(f, 0, 0, 0, -1, 0) for f in range(3)]
    return [(f, 0, 0, 0, 0, 0) for f in range(6)]


def _split(cell) -> list:
    """The cell's four quarters, or its form-factor interval's halves where that interval
    is the wider (in the face coordinates' units)."""
    face, level, i, j, tl, k = cell
    if tl >= 0 and TAU_MAX / (1 << tl) > 2.0 / (1 << level):
        return [(face, level, i, j, tl + 1, 2 * k + h) for h in (0, 1)]
    return [(face, level + 1, 2 * i + di, 2 * j + dj, tl, k) for di in (0, 1) for dj in (0, 1)]


def _size(cell) -> float:
    level, tl = cell[1], cell[4]
    return max(2.0 / (1 << level), TAU_MAX / (1 << tl) if tl >= 0 else 0.0)


_STATE = {}


def _init(normals, ref, faces, limits):
    n = len(ref)
    _STATE["limits"] = limits
    _STATE["full"] = Relaxation(normals, ref, n, faces)
    _STATE["subset"] = Relaxation(normals[::SUBSET_STRIDE], ref[::SUBSET_STRIDE], n, faces)


def _judge(node):
    """``(node, verdict, bound)``: ``infeasible`` (no fit within the max), ``bound`` (the least
    mean above the limit) or ``open``. Infeasible: by the dual simplex on every
    :data:`SUBSET_STRIDE`-th normal, else by the interior point on all of them, with and
    without presolve (the dual simplex takes minutes there)."""
    mean_tol, max_tol = _STATE["limits"]
    cap = max_tol + SOLVER_MARGIN
    if _STATE["subset"].lower(node, cap, "highs-ds", presolve=True) == np.inf:
        return node, "infeasible", np.inf
    lb = _STATE["full"].lower(node, cap)
    if lb == np.inf:  # the other path (presolved) must agree
        lb = _STATE["full"].lower(node, cap, presolve=True)
    if lb == np.inf:
        return node, "infeasible", lb
    return node, "bound" if lb > mean_tol + SOLVER_MARGIN else "open", lb


def branch_and_bound(
    normals,
    ref,
    family: str,
    lights: int,
    limits: tuple,
    workers: int = 1,
    max_level: int = MAX_LEVEL,
    log=None,
) -> dict:
    """Whether any ``lights`` lights of ``family`` (``directional`` or ``rect``) + 9
    coefficients keep the mean relative error at ``normals`` (brute-force luminance ``ref``)
    ≤ ``limits[0]`` with every error ≤ ``limits[1]``: ``proved`` (none can)
    or not (a tuple of cells finer than ``max_level`` was left), and each generation's
    counts. ``workers`` processes; ``log``: called with each generation's counts."""
    faces = _faces(3 if family == "directional" else 6)
    nodes = sorted(
        {tuple(sorted(c)) for c in itertools.combinations_with_replacement(_roots(family), lights)}
    )
    generations, t0 = [], time.perf_counter()
    state = (normals, ref, faces, limits)
    pool = multiprocessing.get_context("fork").Pool(workers, _init, state) if workers > 1 else None
    if pool is None:
        _init(*state)

    def judged(batch):
        return pool.imap_unordered(_judge, batch, chunksize=4) if pool else map(_judge, batch)

    try:
        while nodes:
            verdicts = {"infeasible": 0, "bound": 0, "open": 0}
            survivors, least = [], np.inf
            for node, verdict, lb in judged(nodes):
                verdicts[verdict] += 1
                if verdict == "open":
                    survivors.append(node)
                    least = min(least, lb)
            finest = max(c[1] for n in nodes for c in n)
            generations.append({"triples": len(nodes), **verdicts, "finest_level": finest,
                                "least_open_bound": None if least == np.inf else least,
                                "seconds": round(time.perf_counter() - t0, 1)})  # fmt: skip
            if log:
                log(generations[-1])
            if finest > max_level:
                break
            children = set()
            for node in survivors:
                q = max(range(lights), key=lambda i: _size(node[i]))
                for c in _split(node[q]):
                    children.add(tuple(sorted(node[:q] + (c,) + node[q + 1 :])))
            nodes = sorted(children)
    finally:
        if pool:
            pool.close()
            pool.join()
    return {
        "proved": not nodes,
        "generations": generations,
        "seconds": round(time.perf_counter() - t0, 1),
    }
