"""The error measures shbake reports, one definition each (``docs/CONVENTIONS.md`` § Error
measures).

``got`` and ``ref`` are arrays of the same shape (values over points and channels); the
sums run over every element.

- :func:`mean_squared_error`: ``mean((got − ref)²)`` — ``preview --diff`` (``mse``),
  ``probe-eval`` (per case);
- :func:`relative_rms_error`: ``sqrt(Σ (got − ref)² / Σ ref²)`` — ``preview --diff``
  (``relative_rms_error``), the scene bake's ``irradiance``/``tangent_irradiance`` errors
  (the quantity of the scene's tolerances);
- :func:`relative_error_energy`: ``Σ (got − ref)² / Σ ref²``, its square — the SHRM checks
  (comparable with the BRDF energy the orders leave out);
- :func:`mean_relative_error`, :func:`max_relative_error`: ``mean``/``max`` of the
  pointwise ``|got − ref| / ref`` — ``project-env --report``;
- :func:`mean_relative_norm`: ``mean_k sqrt(e_k / E_k)`` over rows ``k`` given their
  squared error norms ``e_k`` and reference energies ``E_k`` — a BRDF table's error (its
  rows the probe views, the reference ``f*``: ``plan``, ``tradeoff``, the scene bake).

The relative RMS error weighs points by their brightness (a scene's tolerance: how much of
the signal is wrong); the mean relative error weighs every point alike (dark directions
count as much as bright ones), so the two differ on maps with a bright sun.
"""

import numpy as np

HEADLINE_WARNING = {"env_sh": 0.02, "shexp_probe": 0.25}
"""Headline error (relative RMS of luminance against brute force, of what a consumer
evaluates) above which the command that bakes an asset kind warns and names what lowers it:
``project-env --report`` (its exports' 9 coefficients and lights, or the asset) and
``probe-fit`` (E0 shaded from the probe). The overview judges against these where nothing
else names a tolerance."""
TINY = 1e-300
"""Floor of a denominator (an all-black reference)."""
BLACK_LEVEL = 1e-20
"""Radiance at or below which a result counts as black (a probe of a black map shades its
fit's floor, ~1e-30; half floats flush below 6e-8): against a black reference it is no
error."""


def mean_squared_error(got, ref) -> float:
    """``mean((got − ref)²)``; 0 for empty arrays.

    >>> mean_squared_error([1.0, 2.0], [1.0, 4.0])
    2.0
    """
    d = np.asarray(got, dtype=np.float64) - np.asarray(ref, dtype=np.float64)
    return float(np.mean(d * d)) if d.size else 0.0


def relative_error_energy(got, ref) -> float:
    """``Σ (got − ref)² / Σ ref²``: the fraction of the reference's energy that is error.
    Against a black reference: 0 if ``got`` is black too (every value at most
    :data:`BLACK_LEVEL`), else infinite.

    >>> relative_error_energy([1.0, 1.0], [1.0, 2.0])
    0.2
    >>> relative_error_energy([1e-30, 0.0], [0.0, 0.0])
    0.0
    """
    r = np.asarray(ref, dtype=np.float64)
    g = np.asarray(got, dtype=np.float64)
    energy = float(np.sum(r * r))
    if energy == 0.0:
        return 0.0 if not g.size or float(np.max(np.abs(g))) <= BLACK_LEVEL else float("inf")
    d = g - r
    return float(np.sum(d * d) / max(energy, TINY))


def relative_rms_error(got, ref) -> float:
    """``sqrt(Σ (got − ref)² / Σ ref²)``, the square root of :func:`relative_error_energy`.

    >>> relative_rms_error([3.0, 0.0], [4.0, 0.0])
    0.25
    """
    return float(np.sqrt(relative_error_energy(got, ref)))


def relative_errors(got, ref, floor: float = 1e-30) -> np.ndarray:
    """Pointwise ``|got − ref| / max(ref, floor)``."""
    r = np.asarray(ref, dtype=np.float64)
    return np.abs(np.asarray(got, dtype=np.float64) - r) / np.maximum(r, floor)


def mean_relative_error(got, ref) -> float:
    """``mean(|got − ref| / ref)`` (:func:`relative_errors`).

    >>> mean_relative_error([1.5, 2.0], [1.0, 2.0])
    0.25
    """
    return float(np.mean(relative_errors(got, ref)))


def max_relative_error(got, ref) -> float:
    """``max(|got − ref| / ref)`` (:func:`relative_errors`)."""
    return float(np.max(relative_errors(got, ref)))


def mean_relative_norm(error_energy, energy) -> float:
    """``mean_k sqrt(e_k / E_k)``: per row ``k`` the norm of the error relative to the
    reference's, averaged over the rows. ``error_energy``: ``e_k``, the squared norm of row
    ``k``'s error; ``energy``: ``E_k``, the reference's squared norm (a BRDF table's row is
    a view ``v`` and ``E_k = ∫ f*(s, v)² ds``, so truncation counts as error).

    >>> mean_relative_norm([1.0, 0.0], [4.0, 1.0])
    0.25
    """
    e = np.asarray(error_energy, dtype=np.float64)
    return float(np.mean(np.sqrt(e / np.maximum(np.asarray(energy, dtype=np.float64), TINY))))
