"""SH projection of the BRDF product function per view direction (Kautz et al. 2002, §3).

For each view ``v``::

    c_i(v) = ∫ y_i(s) f(s, v) max(0, s_z) ds                  (Kautz et al. 2002, §3)

by deterministic quadrature with importance sampling. The integrand
``g = y_i f s_z`` is split by the balance heuristic (Veach & Guibas 1995)
between two strategies, ``g = g p_c/(p_c + p_l) + g p_l/(p_c + p_l)`` with
``p_c = s_z/π`` (cosine) and ``p_l`` the model's lobe density:

* the hemisphere part on a product rule, Gauss–Legendre in ``θ`` × trapezoid
  in ``φ`` (spectrally accurate for smooth integrands: a Lambert table is exact);
* the lobe part on the lobe sampler's square ``(u_r, u_a)``, Gauss–Legendre
  × midpoint, integrand ``g / (p_c + p_l)``.

On each line of constant ``u_a`` the lobe rule's Gauss–Legendre nodes span
only the part of ``u_r`` whose directions lie above the horizon (its end
found by bisection): at grazing views some models' ``f*`` jumps at the
horizon (Ashikhmin–Shirley's ``1/max(n·s, n·v)``), and a rule spanning the
crossing would converge only as ``O(1/n)``. Across lines the same happens
in ``u_a``: at grazing views the lines whose first step leaves the mirror
direction downwards hold almost nothing and the others almost all of the
lobe, a step one ``u_a`` node straddles. The ``u_a`` axis is therefore cut at
the quadrant boundaries and at every ``u_a`` where that first step turns from
up to down (found by bisection), and each piece gets its own midpoint rule.

Diffuse models (no lobe) use the first rule alone. ``N`` samples per strategy
means ``n_r = round(sqrt(N/2))`` radial by ``2 n_r`` azimuthal nodes. The
error estimate is the largest change of any coefficient from ``N/2`` to ``N``
samples, times ``sqrt(4π)`` (it reads as an error of the white-furnace value
``Q = sqrt(4π) c_0``).

With ``tol`` each view is refined on *nested* rules instead (Gauss–Legendre
levels share no nodes, so doubling them redoes every sample): Clenshaw–Curtis
radially (Clenshaw & Curtis 1960; the hemisphere's ``θ`` split at ``θ_v``, where
Ashikhmin–Shirley's ``1/max(s_z, v_z)`` kinks), the trapezoid azimuthally
(periodic, or after the sin² substitution on the pieces above). A doubling adds
only the new nodes. Each rule's embedded coarse rules — every second radial node,
every second azimuthal line — come from the same samples; the estimate is
``sqrt(4π) max_i Σ_axes |c_i − c_i,coarse|`` over the 4 axes (2 per strategy),
and the axis with the largest difference is doubled until the estimate is at
most ``tol``. It measures the coarse rules' error, so it bounds the accepted
(finer) rule's; the rules adapt per axis (frontal views refine ``θ``, grazing
views ``u_a``).

Every model here satisfies ``f(σs, σv) = f(s, v)`` for the mirrors
``σ: x → −x`` and ``y → −y``, so only one quadrant of the parabolic map is
integrated and the rest follows from ``c_i(σv) = ±c_i(v)``, exactly.
"""

import itertools
import time
from dataclasses import dataclass, field

import numpy as np

from shbake.brdf.dispatch import brdf_eval, brdf_eval_pdf, lobe_line, lobe_sample_on_line
from shbake.brdf.model import BRDF
from shbake.brdf.sampling import cosine_pdf
from shbake.conventions import KAUTZ_LMAX_LIMIT, SQRT_4PI, check_lmax, n_coeffs
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.resources import check_memory
from shbake.sh.basis import recurrence_tables, sh_eval_into
from shbake.sh.point_sets import gauss_legendre_unit
from shbake.simd import clock_ticks
from shbake.texture.parabolic import check_resolution, taps, texel_views

MAX_SAMPLES_LIMIT = 1 << 22
HALF_PI = 0.5 * np.pi
TWO_PI = 2.0 * np.pi


@jit
def _horizon_span(model, prm, vx, vy, vz, la, lb):
    """The sub-interval of ``u_r ∈ [0, 1]`` whose lobe directions have ``s_z > 0``, on the
    line ``(la, lb) = lobe_line(u_a)``.

    Assumes at most one crossing along the line; ``(0, 0)`` if none is above.
    """
    lo_up = lobe_sample_on_line(model, prm, vx, vy, vz, 0.0, la, lb)[2] > 0.0
    hi_up = lobe_sample_on_line(model, prm, vx, vy, vz, 1.0 - 1e-12, la, lb)[2] > 0.0
    if lo_up and hi_up:
        return 0.0, 1.0
    if not lo_up and not hi_up:
        return 0.0, 0.0
    a, b = 0.0, 1.0 - 1e-12
    for _ in range(48):
        m = 0.5 * (a + b)
        if (lobe_sample_on_line(model, prm, vx, vy, vz, m, la, lb)[2] > 0.0) == lo_up:
            a = m
        else:
            b = m
    return (0.0, a) if lo_up else (b, 1.0)


AZIMUTH_PROBES = 64
FIRST_STEP = 1e-6
STEP_PROBE = 1.0 / 256.0
STEP_JUMP = 0.25


@jit
def _first_step_rise(model, prm, vx, vy, vz, ua):
    """``s_z(u_r = ε, u_a) − s_z(0, u_a)``: whether the lobe line starts upwards."""
    la, lb = lobe_line(model, prm, ua)
    return (
        lobe_sample_on_line(model, prm, vx, vy, vz, FIRST_STEP, la, lb)[2]
        - lobe_sample_on_line(model, prm, vx, vy, vz, 0.0, la, lb)[2]
    )


@jit
def _span_length(model, prm, vx, vy, vz, ua):
    u0, u1 = _horizon_span(model, prm, vx, vy, vz, *lobe_line(model, prm, ua))
    return max(0.0, u1 - u0)


@jit
def _step_cuts(model, prm, vx, vy, vz):
    """The ``u_a`` where the lobe line's first step turns and the span steps.

    Sign changes of :func:`_first_step_rise` are bracketed on a grid of
    ``AZIMUTH_PROBES`` intervals and refined by bisection; one is kept when
    the above-horizon span of ``u_r`` differs by more than ``STEP_JUMP``
    within ``±STEP_PROBE`` of it (a grazing view's step).
    """
    cuts = np.empty(AZIMUTH_PROBES)
    n = 0
    prev = _first_step_rise(model, prm, vx, vy, vz, 0.0)
    for j in range(1, AZIMUTH_PROBES + 1):
        hi = j / AZIMUTH_PROBES
        cur = _first_step_rise(model, prm, vx, vy, vz, hi)
        if (prev > 0.0) != (cur > 0.0):
            a, b = (j - 1) / AZIMUTH_PROBES, hi
            for _ in range(48):
                m = 0.5 * (a + b)
                if (_first_step_rise(model, prm, vx, vy, vz, m) > 0.0) == (prev > 0.0):
                    a = m
                else:
                    b = m
            c = 0.5 * (a + b)
            lo = _span_length(model, prm, vx, vy, vz, max(0.0, c - STEP_PROBE))
            up = _span_length(model, prm, vx, vy, vz, min(1.0 - 1e-12, c + STEP_PROBE))
            if abs(up - lo) > STEP_JUMP:
                cuts[n] = c
                n += 1
        prev = cur
    return cuts[:n]


@jit
def _piece_nodes(n_a, width):
    """Nodes on a piece: its share of ``n_a``, at least ``n_a/16`` (a narrow piece
    beside a step holds its steep side) and 2 (the sin² rule's least)."""
    return max(2, int(round(n_a * width)), n_a // 16)


@jit
def _azimuth_rule(model, prm, vx, vy, vz, n_a):
    """Nodes and weights in ``u_a ∈ [0, 1)`` for the lobe rule.

    Without a step: the midpoint rule on ``n_a`` nodes. With one: the axis is
    cut at the quadrant boundaries and the steps, and each piece of width
    ``w`` gets :func:`_piece_nodes` midpoint nodes after Sidi's sin²
    substitution ``u = t − sin(2πt)/2π``, which clusters them at the cuts.
    """
    steps = _step_cuts(model, prm, vx, vy, vz)
    if steps.size == 0:
        nodes = (np.arange(n_a) + 0.5) / n_a
        return nodes, np.full(n_a, 1.0 / n_a)
    cuts = np.sort(np.concatenate((np.array([0.0, 0.25, 0.5, 0.75, 1.0]), steps)))
    count = 0
    for k in range(cuts.size - 1):
        count += _piece_nodes(n_a, cuts[k + 1] - cuts[k])
    nodes = np.empty(count)
    weights = np.empty(count)
    j = 0
    for k in range(cuts.size - 1):
        width = cuts[k + 1] - cuts[k]
        m = _piece_nodes(n_a, width)
        for i in range(m):
            t = (i + 0.5) / m
            nodes[j] = cuts[k] + width * (t - np.sin(TWO_PI * t) / TWO_PI)
            weights[j] = width / m * (1.0 - np.cos(TWO_PI * t))
            j += 1
    return nodes, weights


@jit
def _integrate(model, prm, data, has_lobe, views, lmax, qmm, a, b, gx, gw, n_a, out, b0, b1):
    """``out[v] = c(v)`` by the two product rules; ``gx, gw`` GL nodes/weights on [0, 1]."""
    n = (lmax + 1) * (lmax + 1)
    for iv in range(b0, b1):
        y = np.empty(n)
        f = np.empty(3)
        acc = np.zeros((n, 3))
        vx, vy, vz = views[iv, 0], views[iv, 1], views[iv, 2]
        # hemisphere rule: GL in θ × trapezoid in φ, weight p_c/(p_c + p_l)
        for ir in range(gx.shape[0]):
            theta = HALF_PI * gx[ir]
            st, ct = np.sin(theta), np.cos(theta)
            w_r = HALF_PI * gw[ir] * st * TWO_PI / n_a
            for ia in range(n_a):
                phi = TWO_PI * (ia + 0.5) / n_a
                sx, sy, sz = st * np.cos(phi), st * np.sin(phi), ct
                w = w_r * sz
                if has_lobe:
                    pc = cosine_pdf(sz)
                    w *= pc / (pc + brdf_eval_pdf(model, prm, data, sx, sy, sz, vx, vy, vz, f))
                else:
                    brdf_eval(model, prm, data, sx, sy, sz, vx, vy, vz, f)
                sh_eval_into(sx, sy, sz, lmax, qmm, a, b, y)
                for i in range(n):
                    yw = y[i] * w
                    for c in range(3):
                        acc[i, c] += yw * f[c]
        # lobe rule: the azimuth rule in u_a × GL over the above-horizon span of u_r
        if has_lobe:
            nodes, weights = _azimuth_rule(model, prm, vx, vy, vz, n_a)
            for ia in range(nodes.size):
                ua = nodes[ia]
                la, lb = lobe_line(model, prm, ua)
                u0, u1 = _horizon_span(model, prm, vx, vy, vz, la, lb)
                if u1 <= u0:
                    continue
                for ir in range(gx.shape[0]):
                    ur = u0 + (u1 - u0) * gx[ir]
                    sx, sy, sz = lobe_sample_on_line(model, prm, vx, vy, vz, ur, la, lb)
                    if sz <= 0.0:
                        continue
                    p = cosine_pdf(sz) + brdf_eval_pdf(model, prm, data, sx, sy, sz, vx, vy, vz, f)
                    if p <= 0.0:
                        continue
                    w = (u1 - u0) * gw[ir] * weights[ia] * sz / p
                    sh_eval_into(sx, sy, sz, lmax, qmm, a, b, y)
                    for i in range(n):
                        yw = y[i] * w
                        for c in range(3):
                            acc[i, c] += yw * f[c]
        for i in range(n):
            for c in range(3):
                out[iv, i, c] = acc[i, c]


# --- the --tol path: nested rules refined per view and per axis -------------------------

R_BASE = 16
"""Clenshaw–Curtis intervals of the base radial rule (``θ`` or ``u_r``); its coarse one has 8."""
A_BASE = 32
"""Azimuthal intervals of the base rule (``φ`` or ``u_a``); its embedded coarse rule has 16."""
R_MAX_LEVEL = 7
"""Radial doublings at most: ``R_BASE · 2^7 = 2048`` intervals."""
FIRST_LEVEL_POINTS = 2 * (R_BASE + 1) * A_BASE
"""Points of the hemisphere rule's first level (``θ`` split at ``θ_v``: two Clenshaw–Curtis
rules of ``R_BASE`` intervals, on ``A_BASE`` lines), which every view integrates whole: the
least ``max_samples`` the ``tol`` path can honour (the lobe rule's first level is
``R_BASE + 1`` nodes on about ``A_BASE`` lines)."""
MAX_STEPS = 64
"""Refinement steps recorded per view (:attr:`Convergence.history`)."""
UR_TOP = 1.0 - 1e-12


def clenshaw_curtis_unit(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Clenshaw–Curtis nodes ``(1 − cos(kπ/n))/2`` and weights on ``[0, 1]``, ``n`` even.

    Exact for polynomials of degree ``n``; the ``n``-interval nodes hold those
    of ``n/2`` (every second one), so a doubling reuses every earlier sample
    (Clenshaw & Curtis 1960; weights by the cosine sum of Waldvogel 2006, eq. 2.1).
    """
    k = np.arange(n + 1)
    theta = np.pi * k / n
    j = np.arange(1, n // 2 + 1)
    bj = np.where(2 * j == n, 1.0, 2.0) / (4.0 * j * j - 1.0)
    w = 1.0 - bj @ np.cos(2.0 * np.outer(j, theta))
    w *= np.where((k == 0) | (k == n), 1.0, 2.0) / n
    return 0.5 * (1.0 - np.cos(theta)), 0.5 * w


def cc_tables(levels: int = R_MAX_LEVEL) -> tuple[np.ndarray, np.ndarray]:
    """Concatenated Clenshaw–Curtis weights of radial levels ``−1 … levels`` and their offsets.

    Level ``L`` has ``R_BASE · 2^L`` intervals; its weights start at ``offsets[L + 1]``.
    """
    ws = [clenshaw_curtis_unit(R_BASE << L if L >= 0 else R_BASE // 2)[1]
          for L in range(-1, levels + 1)]  # fmt: skip
    offsets = np.cumsum([0] + [w.size for w in ws])
    return np.concatenate(ws), offsets.astype(np.int64)


@jit
def _point(kind, model, prm, data, has_lobe, vx, vy, vz, ca, sa, u0, u1, x, st, sz, f):
    """One node of a rule: its weight (``0``: skip) and direction; ``f`` gets ``f(s, v)``.

    Hemisphere (``kind`` 0): ``θ = x`` (``st, sz = sin θ, cos θ``, once per row) on the
    line ``(cos φ, sin φ) = (ca, sa)``, weight ``sin θ cos θ · p_c/(p_c + p_l)``. Lobe
    (``kind`` 1): ``u_r = u0 + (u1 − u0) x`` on the line ``(ca, sa) = lobe_line(u_a)``,
    weight ``(u1 − u0) s_z/(p_c + p_l)``.
    """
    if kind == 0:
        if x <= 0.0 or x >= HALF_PI:  # the pole (sin θ = 0) and the horizon (s_z = 0)
            return 0.0, 0.0, 0.0, 0.0
        sx, sy = st * ca, st * sa
        w = st * sz
        if has_lobe:
            pc = cosine_pdf(sz)
            w *= pc / (pc + brdf_eval_pdf(model, prm, data, sx, sy, sz, vx, vy, vz, f))
        else:
            brdf_eval(model, prm, data, sx, sy, sz, vx, vy, vz, f)
        return w, sx, sy, sz
    if u1 <= u0:
        return 0.0, 0.0, 0.0, 0.0
    ur = min(u0 + (u1 - u0) * x, UR_TOP)
    sx, sy, sz = lobe_sample_on_line(model, prm, vx, vy, vz, ur, ca, sa)
    if not sz > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    p = cosine_pdf(sz) + brdf_eval_pdf(model, prm, data, sx, sy, sz, vx, vy, vz, f)
    if not p > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    return (u1 - u0) * sz / p, sx, sy, sz


@jit
def _fill(kind, model, prm, data, has_lobe, vx, vy, vz, lmax, qmm, a, b,
          rx, rj, r0, r1, lc, ls, lu0, lu1, lw, lborn, j0, j1, level_a, tc, tf, y, f):  # fmt: skip
    """Add the nodes ``rows r0…r1 × lines j0…j1`` to the per-row sums ``tc``/``tf``.

    A line born at the current azimuthal level ``level_a`` adds to ``tf`` (absent
    from the embedded coarse azimuthal rule), any other to ``tc``.
    """
    n = (lmax + 1) * (lmax + 1)
    for r in range(r0, r1):
        x = rx[r]
        st, ct = (np.sin(x), np.cos(x)) if kind == 0 else (0.0, 0.0)
        for j in range(j0, j1):
            w, sx, sy, sz = _point(kind, model, prm, data, has_lobe, vx, vy, vz,
                                   lc[j], ls[j], lu0[j], lu1[j], x, st, ct, f)  # fmt: skip
            if w == 0.0:
                continue
            w *= lw[j] * rj[r]
            sh_eval_into(sx, sy, sz, lmax, qmm, a, b, y)
            f0, f1, f2 = w * f[0], w * f[1], w * f[2]
            t = tf if lborn[j] == level_a else tc
            for i in range(n):
                t[r, i, 0] += y[i] * f0
                t[r, i, 1] += y[i] * f1
                t[r, i, 2] += y[i] * f2


@jit
def _add_lines(kind, model, prm, vx, vy, vz, level, pc, pw, pm, lc, ls, lu0, lu1, lw, lborn, j):
    """Append the lines of azimuthal ``level`` (all of level 0, else the new odd ones) at ``j``.

    No pieces (``pc.size == 0``): the periodic trapezoid, ``A_BASE · 2^level``
    lines ``u = i/M``. Pieces ``[pc, pc + pw]`` of ``pm`` base intervals: the
    sin² substitution ``u = t − sin(2πt)/2π`` (Sidi 1993), trapezoid in ``t``
    (its end nodes have weight 0). Weights are stored at level 0's scale; level
    ``L`` multiplies them by ``2^−L``. Returns the new line count.
    """
    step = 1 if level == 0 else 2
    first = 0 if level == 0 else 1
    if pc.size == 0:
        m = A_BASE << level
        for i in range(first, m, step):
            u = i / m
            lborn[j] = level if (level > 0 or i % 2 == 1) else -1
            if kind == 0:
                lc[j], ls[j] = np.cos(TWO_PI * u), np.sin(TWO_PI * u)
                lw[j] = TWO_PI / A_BASE
            else:
                lc[j], ls[j] = lobe_line(model, prm, u)
                lw[j] = 1.0 / A_BASE
                lu0[j], lu1[j] = _horizon_span(model, prm, vx, vy, vz, lc[j], ls[j])
            j += 1
        return j
    for k in range(pc.size):
        m = pm[k] << level
        for i in range(max(first, 1), m, step):
            t = i / m
            lborn[j] = level if (level > 0 or i % 2 == 1) else -1
            u = pc[k] + pw[k] * (t - np.sin(TWO_PI * t) / TWO_PI)
            lc[j], ls[j] = lobe_line(model, prm, u)
            lw[j] = pw[k] / pm[k] * (1.0 - np.cos(TWO_PI * t))
            lu0[j], lu1[j] = _horizon_span(model, prm, vx, vy, vz, lc[j], ls[j])
            j += 1
    return j


@jit
def _add_rows(g, k, m, level, tv, rx, rj, rk, rb, tc, tf, r):
    """Append Clenshaw–Curtis node ``k`` of ``m`` intervals at row ``r``; the new row count.

    The lobe rule (``g`` 1) maps it to ``x ∈ [0, 1]``; the hemisphere rule
    (``g`` 0) to ``θ`` on each of ``[0, θ_v]`` and ``[θ_v, π/2]`` (two rows): a
    model's ``f`` may kink at ``s_z = v_z`` (Ashikhmin–Shirley's
    ``1/max(s_z, v_z)``), which a rule spanning ``θ_v`` would converge on
    only algebraically, its successive levels then agreeing by accident.
    """
    x = 0.5 * (1.0 - np.cos(np.pi * k / m))
    for p in range(2 if g == 0 else 1):
        if g == 0:
            lo, hi = (0.0, tv) if p == 0 else (tv, HALF_PI)
            rx[r], rj[r] = lo + (hi - lo) * x, hi - lo
        else:
            rx[r], rj[r] = x, 1.0
        rk[r] = k
        rb[r] = level
        tc[r] = 0.0
        tf[r] = 0.0
        r += 1
    return r


@jit
def _rule_sums(tc, tf, rk, rb, nrow, lr, la, ccw, ccoff, q, qr, qa):
    """``q``: the rule; ``qr``, ``qa``: its embedded coarse radial and azimuthal rules."""
    s = 0.5**la
    fine, coarse = ccoff[lr + 1], ccoff[lr]
    q[:] = 0.0
    qr[:] = 0.0
    qa[:] = 0.0
    for r in range(nrow):
        k = rk[r] << (lr - max(rb[r], 0))
        w = s * ccw[fine + k]
        wc = s * ccw[coarse + k // 2] if k % 2 == 0 else 0.0
        for i in range(q.shape[0]):
            for c in range(3):
                t = tc[r, i, c] + tf[r, i, c]
                q[i, c] += w * t
                qr[i, c] += wc * t
                qa[i, c] += 2.0 * w * tc[r, i, c]


@jit
def _view_nested(model, prm, data, has_lobe, vx, vy, vz, lmax, qmm, a, b, ccw, ccoff,
                 tol, max_samples, line_cap, out, hist):  # fmt: skip
    """Refine one view's two rules axis by axis until the error estimate is ≤ ``tol``.

    Returns ``(steps, error estimate, samples)``; ``out`` gets the coefficients,
    ``hist[k] = (hemisphere points, lobe points, estimate, ticks)`` per step, ``ticks``
    the :func:`~shbake.simd.clock_ticks` spent on this view up to the step's estimate.
    """
    start = clock_ticks()
    n = (lmax + 1) * (lmax + 1)
    rules = 2 if has_lobe else 1
    rcap = 2 * ((R_BASE << R_MAX_LEVEL) + 1)
    tv = np.arccos(vz)
    tc = np.empty((rules, rcap, n, 3))
    tf = np.empty((rules, rcap, n, 3))
    rx = np.empty((rules, rcap))
    rj = np.empty((rules, rcap))
    rk = np.empty((rules, rcap), np.int64)
    rb = np.empty((rules, rcap), np.int64)
    lc = np.empty((rules, line_cap))
    ls = np.empty((rules, line_cap))
    lu0 = np.empty((rules, line_cap))
    lu1 = np.empty((rules, line_cap))
    lw = np.empty((rules, line_cap))
    lborn = np.empty((rules, line_cap), np.int64)
    nrow = np.zeros(rules, np.int64)
    nline = np.zeros(rules, np.int64)
    lr = np.zeros(rules, np.int64)
    la = np.zeros(rules, np.int64)
    y = np.empty(n)
    f = np.empty(3)
    no_pieces = np.empty(0)
    pc, pw, pm = no_pieces, no_pieces, np.empty(0, np.int64)
    if has_lobe:
        steps = _step_cuts(model, prm, vx, vy, vz)
        if steps.size > 0:
            cuts = np.sort(np.concatenate((np.array([0.0, 0.25, 0.5, 0.75, 1.0]), steps)))
            pc = cuts[:-1].copy()
            pw = cuts[1:] - cuts[:-1]
            pm = np.empty(pc.size, np.int64)
            for k in range(pc.size):
                m = _piece_nodes(A_BASE, pw[k])
                pm[k] = m + (m % 2)
    # Integer arguments below are int64 variables, never literals (``0``, ``R_BASE``, a
    # ``-1`` start): numba compiles a callee once per literal argument value, and each such
    # copy of ``_fill`` (which inlines every BRDF model) cost ~1 s of cold compile.
    zero = np.int64(0)
    for g in range(rules):
        for k in range(R_BASE + 1):
            nrow[g] = _add_rows(g, k, R_BASE << lr[g], 0 if k % 2 == 1 else -1, tv, rx[g], rj[g],
                                rk[g], rb[g], tc[g], tf[g], nrow[g])  # fmt: skip
        gp = (no_pieces, no_pieces, pm[:0]) if g == 0 else (pc, pw, pm)
        nline[g] = _add_lines(g, model, prm, vx, vy, vz, la[g], gp[0], gp[1], gp[2],
                              lc[g], ls[g], lu0[g], lu1[g], lw[g], lborn[g], zero)  # fmt: skip
        _fill(g, model, prm, data, has_lobe, vx, vy, vz, lmax, qmm, a, b, rx[g], rj[g], zero,
              nrow[g], lc[g], ls[g], lu0[g], lu1[g], lw[g], lborn[g], zero, nline[g], la[g],
              tc[g], tf[g], y, f)  # fmt: skip
    q = np.empty((rules, n, 3))
    qr = np.empty((rules, n, 3))
    qa = np.empty((rules, n, 3))
    step = 0
    est = 0.0
    while True:
        for g in range(rules):
            _rule_sums(tc[g], tf[g], rk[g], rb[g], nrow[g], lr[g], la[g], ccw, ccoff,
                       q[g], qr[g], qa[g])  # fmt: skip
        est = 0.0
        for i in range(n):
            for c in range(3):
                e = 0.0
                for g in range(rules):
                    e += abs(q[g, i, c] - qr[g, i, c]) + abs(q[g, i, c] - qa[g, i, c])
                est = max(est, e)
        est *= SQRT_4PI
        if step < hist.shape[0]:
            hist[step, 0] = nrow[0] * nline[0]
            hist[step, 1] = nrow[1] * nline[1] if rules == 2 else 0
            hist[step, 2] = est
            hist[step, 3] = clock_ticks() - start
        step += 1
        if est <= tol:
            break
        # the axis with the largest embedded difference whose doubling fits max_samples
        best, best_g, best_ax = -1.0, zero - 1, -1
        for g in range(rules):
            grow_a = 2 * nline[g] + (0 if g == 0 else pc.size)
            for ax in range(2):
                if ax == 0:
                    grow_r = nrow[g] + (2 - g) * (R_BASE << lr[g])  # new odd nodes, per piece
                    fits = lr[g] < R_MAX_LEVEL and grow_r * nline[g] <= max_samples
                    d = qr[g]
                else:
                    fits = grow_a <= line_cap and nrow[g] * grow_a <= max_samples
                    d = qa[g]
                if not fits:
                    continue
                score = np.max(np.abs(q[g] - d))
                if score > best:
                    best, best_g, best_ax = score, g, ax
        if best_g < 0:
            break
        g = best_g
        if best_ax == 0:  # radial doubling: the odd nodes of the finer Clenshaw–Curtis rule
            lr[g] += 1
            m = R_BASE << lr[g]
            r0 = nrow[g]
            for k in range(1, m, 2):
                nrow[g] = _add_rows(g, k, m, lr[g], tv, rx[g], rj[g], rk[g], rb[g], tc[g], tf[g],
                                    nrow[g])  # fmt: skip
            _fill(g, model, prm, data, has_lobe, vx, vy, vz, lmax, qmm, a, b, rx[g], rj[g],
                  r0, nrow[g], lc[g], ls[g], lu0[g], lu1[g], lw[g], lborn[g], zero, nline[g], la[g],
                  tc[g], tf[g], y, f)  # fmt: skip
        else:  # azimuthal doubling: last level's new lines join the coarse rule
            la[g] += 1
            for r in range(nrow[g]):
                for i in range(n):
                    for c in range(3):
                        tc[g, r, i, c] += tf[g, r, i, c]
                        tf[g, r, i, c] = 0.0
            j0 = nline[g]
            gp = (no_pieces, no_pieces, pm[:0]) if g == 0 else (pc, pw, pm)
            nline[g] = _add_lines(g, model, prm, vx, vy, vz, la[g], gp[0], gp[1], gp[2],
                                  lc[g], ls[g], lu0[g], lu1[g], lw[g], lborn[g], j0)  # fmt: skip
            _fill(g, model, prm, data, has_lobe, vx, vy, vz, lmax, qmm, a, b, rx[g], rj[g],
                  zero, nrow[g], lc[g], ls[g], lu0[g], lu1[g], lw[g], lborn[g], j0, nline[g], la[g],
                  tc[g], tf[g], y, f)  # fmt: skip
    for i in range(n):
        for c in range(3):
            s = 0.0
            for g in range(rules):
                s += q[g, i, c]
            out[i, c] = s
    samples = nrow[0] * nline[0]
    if rules == 2:
        samples = max(samples, nrow[1] * nline[1])
    return step, est, samples


@jit
def _nested_block(model, prm, data, has_lobe, views, order, lmax, qmm, a, b, ccw, ccoff,
                  tol, max_samples, line_cap, out, errors, used, steps, hist, b0, b1):  # fmt: skip
    """:func:`_view_nested` for views ``order[b0:b1]`` (one block per view)."""
    for t in range(b0, b1):
        iv = order[t]
        s, e, m = _view_nested(model, prm, data, has_lobe, views[iv, 0], views[iv, 1],
                               views[iv, 2], lmax, qmm, a, b, ccw, ccoff, tol, max_samples,
                               line_cap, out[iv], hist[iv])  # fmt: skip
        steps[iv], errors[iv], used[iv] = s, e, m


def radial_nodes(samples: int) -> int:
    """Radial node count ``n_r`` of a rule with about ``samples`` points (``n_r × 2 n_r``).

    ``n_r`` is even so that ``2 n_r`` azimuthal nodes split evenly into the
    four quadrants some lobe samplers map separately.
    """
    return max(2, 2 * int(round(np.sqrt(samples / 8.0))))


def mirror_signs(lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """Signs ``s_i`` with ``y_i(σd) = s_i y_i(d)`` for ``σ: x → −x`` and for ``σ: y → −y``."""
    sx, sy = [], []
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            sx.append((-1.0) ** abs(m) * (-1.0 if m < 0 else 1.0))
            sy.append(-1.0 if m < 0 else 1.0)
    return np.array(sx), np.array(sy)


@dataclass
class Convergence:
    """How the quadrature converged.

    ``samples``: the most points per strategy any view used; ``error``: the
    largest per-view error estimate; ``view_errors``/``view_samples``: per view;
    ``history``: one entry per sample level (``samples``, ``views``,
    ``error_estimate``, cumulative ``seconds``). With ``tol`` the levels are
    powers of two of points: the views refined into each and their largest
    estimate there; the seconds are the wall time shared out by the kernels'
    measured ticks up to each level (:func:`_nested_history`).
    """

    samples: int
    error: float
    seconds: float
    history: list = field(default_factory=list)
    view_errors: np.ndarray | None = None
    view_samples: np.ndarray | None = None

    def as_dict(self) -> dict:
        return {
            "samples": self.samples,
            "error_estimate": self.error,
            "seconds": self.seconds,
            "history": self.history,
        }


def _check_sampling(samples, tol, max_samples):
    if tol is not None and not (np.isfinite(tol) and 0 < tol < 1):
        raise ParameterError(f"tol must be in (0, 1), got {tol}")
    least, most = FIRST_LEVEL_POINTS, MAX_SAMPLES_LIMIT
    if not isinstance(max_samples, int) or not least <= max_samples <= most:
        raise ParameterError(f"max_samples must be an integer in [{least}, {most}], "
                             f"got {max_samples}")  # fmt: skip
    if samples is not None and (not isinstance(samples, int) or not 16 <= samples <= max_samples):
        raise ParameterError(f"samples must be an integer in [16, {max_samples}], got {samples}")


def project_views(
    brdf: BRDF,
    views,
    lmax: int = 4,
    samples: int | None = 1024,
    tol: float | None = None,
    max_samples: int = 1 << 16,
    progress=None,
    advance=None,
) -> tuple[np.ndarray, Convergence]:
    """SH coefficients of ``f*(·, v)`` for arbitrary view directions.

    Parameters
    ----------
    brdf : BRDF
    views : array_like, (V, 3)
        Unit local-frame view directions, ``v_z > 0``.
    lmax : int, 0 … 16
    samples : int, optional
        Points per strategy (≥ 16). Ignored when ``tol`` is given.
    tol : float, optional
        Refine each view's nested rules (module docstring) until the error
        estimate is at most ``tol`` or no doubling fits ``max_samples`` points
        per strategy (or 2048 radial intervals).
    max_samples : int, FIRST_LEVEL_POINTS … MAX_SAMPLES_LIMIT
        Points per strategy the ``tol`` refinement stops at, and the most ``samples``
        without it; at least the nested rules' first level (:data:`FIRST_LEVEL_POINTS`),
        which every view integrates whole.
    progress : callable(samples, error), optional
    advance : callable(views), optional
        Called as views are finished (a progress bar's step; ``V`` in all).

    Returns
    -------
    coeffs : ndarray, (V, (lmax+1)^2, 3)
    convergence : Convergence
    """
    lmax = check_lmax(lmax, limit=KAUTZ_LMAX_LIMIT)
    _check_sampling(samples, tol, max_samples)
    v = np.ascontiguousarray(np.asarray(views, dtype=float).reshape(-1, 3))
    if np.any(v[:, 2] <= 0) or np.any(np.abs(np.linalg.norm(v, axis=1) - 1) > 1e-9):
        raise ParameterError("view directions must be unit vectors with z > 0")
    qmm, a, b = recurrence_tables(lmax)
    model, prm, data = brdf.spec.model_id, brdf.packed, brdf.data
    t0 = time.perf_counter()

    if tol is not None:
        coeffs, conv = _project_nested(brdf, v, lmax, qmm, a, b, tol, max_samples, advance)
        if progress is not None:
            progress(conv.samples, conv.error)
        return coeffs, conv
    n_half = max(samples // 2, 8)
    rules = []  # the half rule (for the error estimate), then the full one
    for n_samples in (n_half, 2 * n_half):
        nr = radial_nodes(n_samples)
        rules.append((*gauss_legendre_unit(nr), nr))
    prev, coeffs = (np.empty((v.shape[0], n_coeffs(lmax), 3)) for _ in rules)
    cuts = np.unique(np.linspace(0, v.shape[0], (ADVANCE_STEPS if advance else 1) + 1,
                                 dtype=int))  # fmt: skip
    for i0, i1 in zip(cuts[:-1], cuts[1:], strict=True):
        sub = np.ascontiguousarray(v[i0:i1])
        for (gx, gw, nr), out in zip(rules, (prev, coeffs), strict=True):
            run_blocks(_integrate, i1 - i0, (i1 - i0) * out[0].size * nr * nr * 16.0, model,
                       prm, data, brdf.spec.has_lobe, sub, lmax, qmm, a, b, gx, gw, 2 * nr,
                       out[i0:i1])  # fmt: skip
        if advance is not None:
            advance(int(i1 - i0))
    errors = SQRT_4PI * np.max(np.abs(coeffs - prev), axis=(1, 2))
    seconds = time.perf_counter() - t0
    history = [{"samples": 2 * n_half, "views": int(v.shape[0]),
                "error_estimate": float(errors.max()), "seconds": seconds}]  # fmt: skip
    if progress is not None:
        progress(2 * n_half, float(errors.max()))
    conv = Convergence(2 * n_half, float(errors.max()), seconds, history)
    conv.view_errors = errors
    conv.view_samples = np.full(v.shape[0], 2 * n_half, dtype=np.int64)
    return coeffs, conv


def _project_nested(brdf, v, lmax, qmm, a, b, tol, max_samples, advance=None):
    """The ``tol`` path of :func:`project_views`: :func:`_view_nested` per view, threaded."""
    ccw, ccoff = cc_tables()
    count = v.shape[0]
    # interleave the views so a run of grazing ones does not land on one thread
    order = np.argsort(np.arange(count) % 16, kind="stable")
    out = np.empty((count, n_coeffs(lmax), 3))
    errors = np.empty(count)
    used = np.empty(count, np.int64)
    steps = np.empty(count, np.int64)
    hist = np.zeros((count, MAX_STEPS, 4))
    line_cap = max_samples // (R_BASE + 1) + 8 * A_BASE + 4 * AZIMUTH_PROBES
    t0 = time.perf_counter()
    run_blocks(_nested_block, count, 1e8 * count, brdf.spec.model_id, brdf.packed, brdf.data,
               brdf.spec.has_lobe, v, order, lmax, qmm, a, b, ccw, ccoff, float(tol),
               max_samples, line_cap, out, errors, used, steps, hist, advance=advance)  # fmt: skip
    seconds = time.perf_counter() - t0
    conv = Convergence(int(used.max()), float(errors.max()), seconds,
                       _nested_history(hist, steps, seconds))  # fmt: skip
    conv.view_errors = errors
    conv.view_samples = used
    return out, conv


def _nested_history(hist, steps, seconds):
    """Per power-of-two bucket of points: views refined into it, their largest estimate there.

    The views are refined one at a time, not level by level: a bucket's
    ``seconds`` is the call's wall time times the share of the kernels' measured
    ticks spent (every view) up to that bucket's steps.
    """
    k = np.arange(hist.shape[1])
    live = k[None, :] < np.minimum(steps, hist.shape[1])[:, None]
    points = np.maximum(hist[..., 0], hist[..., 1])
    spent = np.where(live, hist[..., 3], 0.0)  # ticks of each view up to step k (cumulative)
    grand = spent.max(axis=1).sum()
    history = []
    bucket = 1 << int(np.ceil(np.log2(max(points[live].min(), 1))))
    top = points[live].max()
    while True:
        inside = live & (points <= bucket) & (points > bucket / 2)
        upto = np.where(live & (points <= bucket), spent, 0.0).max(axis=1).sum()
        if inside.any():
            history.append({
                "samples": int(bucket),
                "views": int(inside.any(axis=1).sum()),
                "error_estimate": float(hist[..., 2][inside].max()),
                "seconds": float(seconds * upto / max(grand, 1.0)),
            })  # fmt: skip
        if bucket >= top:
            return history
        bucket *= 2


ADVANCE_STEPS = 16
"""Kernel calls a fixed-sample projection is split into when its progress is drawn."""


def quadrant_views(h: int, w: int) -> np.ndarray:
    """The view directions a ``h × w`` table integrates, ``(⌈h/2⌉ ⌈w/2⌉, 3)``: the texel
    centres of the quadrant ``p_x ≥ 0, p_y ≥ 0`` (row-major)."""
    h, w = check_resolution(h, w)
    return texel_views(h, w)[h // 2 :, w // 2 :].reshape(-1, 3)


def tabulate(
    brdf: BRDF,
    lmax: int = 4,
    resolution: tuple[int, int] = (128, 128),
    samples: int | None = 1024,
    tol: float | None = None,
    max_samples: int = 1 << 16,
    progress=None,
    advance=None,
) -> tuple[np.ndarray, Convergence]:
    """The parabolic-map table ``c_i(v)``, shape ``(H, W, (lmax+1)^2, 3)``.

    Only the quadrant ``p_x ≥ 0, p_y ≥ 0`` is integrated (:func:`quadrant_views`); the
    rest is filled by the mirror symmetries (module docstring). Arguments as
    :func:`project_views`; ``convergence.view_errors``/``view_samples`` become ``(H, W)`` maps.
    """
    h, w = check_resolution(*resolution)
    r0, c0 = h // 2, w // 2
    coeffs, conv = project_views(brdf, quadrant_views(h, w), lmax, samples, tol, max_samples,
                                 progress=progress, advance=advance)  # fmt: skip
    n = coeffs.shape[1]
    table = np.empty((h, w, n, 3))
    q = coeffs.reshape(h - r0, w - c0, n, 3)
    sx, sy = mirror_signs(lmax)
    table[r0:, c0:] = q
    cols = w - 1 - np.arange(c0, w)  # mirror column of each computed column
    rows = h - 1 - np.arange(r0, h)
    table[r0:, cols] = q * sx[:, None]
    table[rows, c0:] = q * sy[:, None]
    table[rows[:, None], cols[None, :]] = q * (sx * sy)[:, None]
    for name in ("view_errors", "view_samples"):
        m = getattr(conv, name).reshape(h - r0, w - c0)
        full = np.empty((h, w), m.dtype)
        full[r0:, c0:] = m
        full[r0:, cols] = m
        full[rows, c0:] = m
        full[rows[:, None], cols[None, :]] = m
        setattr(conv, name, full)
    return table, conv


def tabulate_at(
    brdf: BRDF,
    lmax: int,
    resolution: tuple[int, int],
    views: np.ndarray,
    samples: int = 1024,
) -> np.ndarray:
    """The table :func:`tabulate` makes at fixed ``samples``, ``(H, W, (lmax+1)^2, 3)``, with
    only the texels a bilinear fetch at unit ``views (m, 3)`` reads
    (:func:`shbake.texture.parabolic.taps`) computed and the rest zero: the same values there
    (their quadrant texel, mirrored with the same signs), at 4 texels per view instead of
    ``H·W/4`` (a 256² resolution study at 64 views: 256 projections, not 16 384)."""
    h, w = check_resolution(*resolution)
    read = set()
    for v in np.asarray(views, dtype=np.float64).reshape(-1, 3):
        y0, y1, _, x0, x1, _ = taps(h, w, v[0], v[1], v[2])
        read |= {(int(i), int(j)) for i in (y0, y1) for j in (x0, x1)}
    read = sorted(read)
    # tabulate fills rows ≤ h-1-h//2 (columns ≤ w-1-w//2) last, from the mirrored quadrant
    flip_i = np.array([i <= h - 1 - h // 2 for i, _ in read])
    flip_j = np.array([j <= w - 1 - w // 2 for _, j in read])
    i, j = np.array(read).T
    qi, qj = np.where(flip_i, h - 1 - i, i), np.where(flip_j, w - 1 - j, j)
    quadrant, which = np.unique(np.stack([qi, qj], 1), axis=0, return_inverse=True)
    coeffs, _ = project_views(brdf, texel_views(h, w)[tuple(quadrant.T)], lmax, samples)
    sx, sy = mirror_signs(lmax)
    sign = np.where(flip_i[:, None], sy, 1.0) * np.where(flip_j[:, None], sx, 1.0)
    table = np.zeros((h, w) + coeffs.shape[1:])
    table[i, j] = coeffs[which.reshape(-1)] * sign[:, :, None]
    return table


def parse_vary(spec: str) -> tuple[str, np.ndarray]:
    """``"NAME=lo:hi:N"`` → ``(NAME, linspace(lo, hi, N))``; ``N`` in 2…64."""
    try:
        name, rng = spec.split("=", 1)
        lo, hi, count = rng.split(":")
        lo, hi, count = float(lo), float(hi), int(count)
    except ValueError:
        raise ParameterError(f"--vary {spec!r}: expected NAME=lo:hi:N, e.g. nu=10:100:4") from None
    if not 2 <= count <= 64:
        raise ParameterError(f"--vary {spec!r}: N must be in [2, 64]")
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ParameterError(f"--vary {spec!r}: lo and hi must be finite numbers")
    return name.strip(), np.linspace(lo, hi, count)


TABLE_COPIES = 3
"""float64 copies of the tables alive at once (per-point tables, their stack, the asset's)."""


def table_bytes(points: int, resolution, lmax: int) -> float:
    """Memory estimate (bytes) of ``points`` tables of ``resolution`` texels and ``lmax``."""
    h, w = (resolution, resolution) if isinstance(resolution, int) else (resolution or (32, 32))
    return float(points) * h * w * (lmax + 1) ** 2 * 3 * 8 * TABLE_COPIES


def tabulate_axes(
    brdf: BRDF,
    vary: list[tuple[str, np.ndarray]],
    progress=None,
    advance=None,
    **kwargs,
) -> tuple[np.ndarray, list[Convergence]]:
    """Tables over the product of parameter axes: ``(*axis sizes, H, W, n, 3)``.

    Each axis ``(name, values)`` overrides one scalar parameter of ``brdf``;
    every value is validated before any work starts. ``advance(views)``: as
    :func:`project_views`, over every table.
    """
    brdf.spec.check_axes([name for name, _ in vary])
    for name, values in vary:
        for value in values:
            brdf.with_values(**{name: value})
    points = list(itertools.product(*[range(len(v)) for _, v in vary]))
    check_memory(table_bytes(len(points), kwargs.get("resolution"), kwargs.get("lmax", 4)),
                 "this table")  # fmt: skip
    tables, convs = [], []
    for idx, point in enumerate(points):
        b = brdf.with_values(
            **{name: vary[a][1][i] for a, (name, _) in enumerate(vary) for i in [point[a]]}
        )
        cb = None if progress is None else (lambda n, e, idx=idx: progress(idx, len(points), n, e))
        table, conv = tabulate(b, progress=cb, advance=advance, **kwargs)
        tables.append(table)
        convs.append(conv)
    shape = tuple(len(v) for _, v in vary)
    return np.stack(tables).reshape(shape + tables[0].shape), convs
