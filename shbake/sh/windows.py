"""Band windows against ringing, and deringing (Sloan, *Stupid Spherical
Harmonics Tricks*, GDC 2008, §"Windowing").

A window ``w_l`` multiplies band ``l`` of the lighting before a kernel is
applied: ``E_lm = K_l w_l L_lm``. ``WINDOW_METHODS`` lists the names the CLI
accepts.
"""

import numpy as np

from shbake.conventions import band_of_index, check_lmax, lmax_of
from shbake.errors import ParameterError
from shbake.sh.basis import real_sh
from shbake.sh.point_sets import fibonacci_sphere

WINDOW_METHODS = ("none", "hann", "lanczos", "dering")


def window(name: str, lmax: int) -> np.ndarray:
    """Band factors ``w_l``, ``l = 0 … lmax``, of a fixed window.

    ``none``: 1. ``hann``: ``(1 + cos(π l/(lmax+1)))/2``. ``lanczos``:
    ``sinc(l/(lmax+1))``. (``dering`` depends on the lighting: see
    :func:`dering_window`.)
    """
    lmax = check_lmax(lmax)
    l = np.arange(lmax + 1)
    if name == "none":
        return np.ones(lmax + 1)
    if name == "hann":
        return 0.5 * (1.0 + np.cos(np.pi * l / (lmax + 1)))
    if name == "lanczos":
        return np.sinc(l / (lmax + 1))
    raise ParameterError(f"unknown window {name!r}; choose one of {', '.join(WINDOW_METHODS)}")


def _dir(p):
    st = np.sin(p[0])
    return np.array([st * np.cos(p[1]), st * np.sin(p[1]), np.cos(p[0])])


def reconstruction_minimum(coeffs, n_samples: int = 8192) -> tuple[float, np.ndarray]:
    """Minimum over the sphere of ``Σ c_i y_i(d)`` (per channel, the least one).

    A dense Fibonacci lattice locates the basins; the 4 lowest samples of
    each channel are polished by Nelder–Mead on (θ, φ). Returns the minimum
    and the direction where it is attained.
    """
    c = np.asarray(coeffs, dtype=np.float64)
    c2 = c.reshape(c.shape[0], -1)
    lmax = lmax_of(c.shape[0])
    from scipy.optimize import minimize  # only --window dering needs it (~150 ms import)

    dirs = fibonacci_sphere(n_samples)
    vals = real_sh(dirs, lmax) @ c2
    best, best_dir = np.inf, dirs[0]
    for ch in range(c2.shape[1]):
        for k in np.argsort(vals[:, ch])[:4]:
            d = dirs[k]
            p0 = np.array([np.arccos(np.clip(d[2], -1, 1)), np.arctan2(d[1], d[0])])

            def f(p, ch=ch):
                return float(real_sh(_dir(p), lmax) @ c2[:, ch])

            res = minimize(f, p0, method="Nelder-Mead", options={"xatol": 1e-7, "fatol": 1e-12})
            v = min(res.fun, vals[k, ch])
            if v < best:
                best = v
                best_dir = _dir(res.x) if res.fun <= vals[k, ch] else d
    return float(best), best_dir


def dering_window(coeffs, kernels, margin: float = 0.0) -> tuple[np.ndarray, float]:
    """The weakest Gaussian window that makes every convolved reconstruction non-negative.

    Window family ``w_l(t) = exp(-t l(l+1))`` (``t = 0``: no window; ``t → ∞``:
    only the mean). ``t`` is found by bisection so that, for every kernel
    ``K`` in ``kernels`` and every channel, ``min_d Σ K_l w_l c_lm y_lm(d) ≥
    margin · K_0 c_00 y_00`` (relative margin, default 0).

    Parameters
    ----------
    coeffs : array_like, (n, C)
        Lighting coefficients.
    kernels : sequence of array_like
        Band factors, each with at least ``lmax + 1`` entries.

    Returns
    -------
    (window, minimum)
        ``window`` has ``lmax + 1`` entries; ``minimum`` is the least value of
        the windowed reconstructions (≥ 0), found as in
        :func:`reconstruction_minimum`.

    Raises
    ------
    ParameterError
        If the mean radiance of some channel is negative (no window helps).
    """
    c = np.asarray(coeffs, dtype=np.float64).reshape(np.shape(coeffs)[0], -1)
    lmax = lmax_of(c.shape[0])
    if np.any(c[0] < 0):
        raise ParameterError("cannot dering: the mean radiance of a channel is negative")
    bands = band_of_index(lmax)
    l = np.arange(lmax + 1)
    dirs = fibonacci_sphere(4096)
    Y = real_sh(dirs, lmax)
    ks = [np.asarray(k, dtype=np.float64)[: lmax + 1] for k in kernels]

    def lowest(t, polish=False):
        w = np.exp(-t * l * (l + 1))
        worst = np.inf
        for k in ks:
            e = c * (k * w)[bands][:, None]
            floor = margin * k[0] * c[0] * 0.28209479177387814
            if polish:
                m, _ = reconstruction_minimum(e)
                worst = min(worst, m - float(floor.max()))
            else:
                worst = min(worst, float(((Y @ e) - floor).min()))
        return worst, w

    m0, w = lowest(0.0, polish=True)
    if m0 >= 0:
        return w, m0
    lo, hi = 0.0, 1.0
    while lowest(hi)[0] < 0 and hi < 1e6:
        lo, hi = hi, hi * 4.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if lowest(mid)[0] < 0:
            lo = mid
        else:
            hi = mid
    # The lattice may miss a narrow dip: polish, and strengthen until it holds.
    t = hi
    for _ in range(60):
        m, w = lowest(t, polish=True)
        if m >= 0:
            return w, m
        t *= 1.05
    return w, m
