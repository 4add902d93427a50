"""Kajiya–Kay tangent irradiance in closed form (Mehta et al. 2012, §4).

``E(t) = A_0 L_00 y_00 + A_2 Σ_m L_2m y_2m(t)`` (eq. 20); shbake writes it
as the 6-term polynomial of eq. 22 and the 4×4 quadratic form of eq. 23–24,
``E(t) = t̃ᵀ M t̃`` with ``t̃ = (x, y, z, 1)``::

    b0 = sqrt(1/4π) ≈ 0.282095,        b1 = -(1/16) sqrt(15/4π) ≈ -0.0682843,
    b2 = -(3/8) sqrt(5/16π) ≈ -0.118272, b3 = (1/8) sqrt(5/16π) ≈ 0.0394239
    E(t) = b0 L00 + 2 b1 (L2-2 xy + L2-1 yz + L21 xz) + b1 L22 (x² - y²)
           + b2 L20 z² + b3 L20
"""

import numpy as np

B0 = np.sqrt(1.0 / (4.0 * np.pi))
B1 = -np.sqrt(15.0 / (4.0 * np.pi)) / 16.0
B2 = -3.0 / 8.0 * np.sqrt(5.0 / (16.0 * np.pi))
B3 = 1.0 / 8.0 * np.sqrt(5.0 / (16.0 * np.pi))


def six_term(lighting9, t) -> np.ndarray:
    """Eq. 22: tangent irradiance at unit tangents ``t`` (..., 3) from ``L_00, L_2m``.

    ``lighting9`` is ``(9, C)`` raw lighting coefficients; returns ``(..., C)``.
    """
    L = np.asarray(lighting9, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    x, y, z = (t[..., i, None] for i in range(3))
    return (
        B0 * L[0]
        + 2.0 * B1 * (L[4] * x * y + L[5] * y * z + L[7] * x * z)
        + B1 * L[8] * (x * x - y * y)
        + B2 * L[6] * z * z
        + B3 * L[6]
    )


def matrix_form(lighting9) -> np.ndarray:
    """Eq. 24: the symmetric 4×4 matrix ``M`` per channel, shape ``(C, 4, 4)``."""
    L = np.asarray(lighting9, dtype=np.float64)
    c = L.shape[1]
    M = np.zeros((c, 4, 4))
    M[:, 0, 0] = B1 * L[8]
    M[:, 0, 1] = M[:, 1, 0] = B1 * L[4]
    M[:, 0, 2] = M[:, 2, 0] = B1 * L[7]
    M[:, 1, 1] = -B1 * L[8]
    M[:, 1, 2] = M[:, 2, 1] = B1 * L[5]
    M[:, 2, 2] = B2 * L[6]
    M[:, 3, 3] = B0 * L[0] + B3 * L[6]
    return M


def eval_matrix_form(M, t) -> np.ndarray:
    """Eq. 23: ``E(t) = t̃ᵀ M t̃`` for ``M`` (C, 4, 4) and unit tangents ``t`` (..., 3)."""
    t = np.asarray(t, dtype=np.float64)
    th = np.concatenate([t, np.ones(t.shape[:-1] + (1,))], axis=-1)
    return np.einsum("...i,cij,...j->...c", th, np.asarray(M), th)
