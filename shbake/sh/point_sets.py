"""Deterministic point sets on the sphere, the hemisphere and the unit square, and the
Gauss–Legendre rule.

Every quadrature and fit in shbake that needs "n well-spread directions" or Gauss–Legendre
nodes takes them from here, so that two modules never disagree on a lattice.
"""

from functools import lru_cache

import numpy as np

INV_GOLDEN = 0.6180339887498949
"""``1/φ``, the golden-ratio step of the Fibonacci lattices."""


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` near-uniform unit vectors (spherical Fibonacci lattice), ``(n, 3)``, deterministic."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def fibonacci_square(n: int) -> np.ndarray:
    """``n`` points of the 2D Fibonacci lattice in ``[0, 1)²``: ``((k+½)/n, frac(k/φ))``."""
    k = np.arange(n)
    return np.stack([(k + 0.5) / n, np.mod(k * INV_GOLDEN, 1.0)], axis=1)


def hemisphere_fibonacci(n: int) -> np.ndarray:
    """``n`` local directions spread uniformly over the upper hemisphere (``z`` uniform)."""
    u = fibonacci_square(n)
    z = 1.0 - u[:, 0]
    s = np.sqrt(1.0 - z * z)
    phi = 2.0 * np.pi * u[:, 1]
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], 1)


@lru_cache(maxsize=16)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on ``[−1, 1]`` (``n`` nodes; exact for polynomials
    of degree ``2n − 1``), read-only and cached (``leggauss`` is O(n³)).

    >>> x, w = gauss_legendre(3)
    >>> round(float(w @ x**4), 12)  # ∫ x⁴ dx over [−1, 1] = 2/5
    0.4
    """
    x, w = np.polynomial.legendre.leggauss(n)
    x.flags.writeable = w.flags.writeable = False
    return x, w


def gauss_legendre_unit(k: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on ``[0, 1]`` (``k`` nodes, :func:`gauss_legendre`
    mapped)."""
    x, w = gauss_legendre(k)
    return 0.5 * (x + 1.0), 0.5 * w
