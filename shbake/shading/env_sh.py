"""What an engine's shader does with an ``env_sh`` asset: SH irradiance plus the sun.

Shaders (:mod:`shbake.shading.shader`): ``irradiance`` (:class:`IrradianceShader`),
``tangent`` (:class:`TangentShader`, the matrix form) and ``tangent-sh``
(:class:`TangentSHShader`).

Lambert (``/irradiance/sh``, ``Â_l`` folded in, SPEC §4)::

    E(n) = Σ_i c_i y_i(n) + max(0, n·s) E_sun

Kajiya–Kay tangent irradiance (Mehta et al. 2012), from ``/tangent_irradiance/sh``
(``A_l`` folded in) or the 4×4 matrix of eq. 23–24 (``/tangent_irradiance/matrix``)::

    E(t) = Σ_i c_i y_i(t) + sqrt(1 − (t·s)²)/π² E_sun = t̃ᵀ M t̃ + sqrt(1 − (t·s)²)/π² E_sun

with ``s`` the sun's direction and ``E_sun = radiance × solid_angle`` its
irradiance at normal incidence (``/sun``, absent when no sun was extracted).
Kernels are check-free: directions unit, arrays from a validated asset.
"""

import numpy as np

from shbake.errors import ParameterError
from shbake.jit import jit, pjit, prange
from shbake.sh.basis import evaluate
from shbake.shading.shader import Shader, Texture, Uniform

INV_PI = 1.0 / np.pi
INV_PI2 = 1.0 / (np.pi * np.pi)


@jit
def sun_lambert(c):
    """Lambert factor ``max(0, n·s)`` of a directional light, ``c = n·s`` (``py_func``: arrays)."""
    return np.maximum(c, 0.0)


@jit
def sun_tangent(c):
    """Kajiya–Kay diffuse factor ``sqrt(1 − (t·s)²)/π²`` of a directional light, ``c = t·s``
    (``py_func``: arrays)."""
    return np.sqrt(np.maximum(0.0, 1.0 - c * c)) * INV_PI2


@pjit
def _matrix_with_sun(tangents, M, sun_dir, sun_energy, out):
    for p in prange(tangents.shape[0]):
        t = (tangents[p, 0], tangents[p, 1], tangents[p, 2], 1.0)
        k = sun_tangent(t[0] * sun_dir[0] + t[1] * sun_dir[1] + t[2] * sun_dir[2])
        for ch in range(3):
            e = k * sun_energy[ch]
            for r in range(4):
                for s in range(4):
                    e += t[r] * M[ch, r, s] * t[s]
            out[p, ch] = e


def sun_of(asset):
    """``(direction, E_sun)`` of an ``env_sh`` asset; a zero light when it has none."""
    if "/sun/direction" in asset:
        return (
            np.asarray(asset["/sun/direction"], float),
            np.asarray(asset["/sun/radiance"], float) * float(asset["/sun/solid_angle"]),
        )
    return np.array([0.0, 0.0, 1.0]), np.zeros(3)


def _flat(dirs):
    d = np.asarray(dirs, dtype=np.float64)
    return d, np.ascontiguousarray(d.reshape(-1, 3))


SUN_INPUTS = (
    Uniform("sun_direction", "unit vector toward the sun, world frame", "/sun/direction",
            "the extracted sun's direction (absent: no sun, zero light)"),
    Uniform("sun_irradiance", "radiance × sr, RGB", "/sun/radiance × /sun/solid_angle",
            "the sun's irradiance at normal incidence E_sun"),
)  # fmt: skip
"""The directional light every ``env_sh`` shader adds (:func:`sun_of`)."""


class IrradianceShader(Shader):
    """A Lambert surface of albedo ``ρ`` under an ``env_sh`` asset: ``ρ E(n) / π`` with
    ``E(n) = Σ_i E_i y_i(n) + max(0, n·s) E_sun`` (module docstring); view-independent."""

    name = "irradiance"
    kinds = ("env_sh",)
    inputs = (
        Texture("irradiance_sh", "sh-vector", ("(lmax_irr+1)**2", 3), "/irradiance/sh",
                "Lambert irradiance SH E_i (Â_l folded in), radiance × sr"),
        *SUN_INPUTS,
        Uniform("albedo", "Lambert albedo ρ, RGB in [0, 1]", "material", "the surface's colour"),
    )  # fmt: skip
    material = {"albedo": ("Lambert albedo ρ, scalar or RGB in [0, 1]", 1.0)}
    truth = "irradiance"
    dataset = "/irradiance/sh"

    def __init__(self, coeffs, sun_direction, sun_irradiance):
        self.coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)
        self.sun_direction, self.sun_irradiance = sun_direction, sun_irradiance

    @classmethod
    def from_asset(cls, asset, **companions):
        if cls.dataset not in asset:
            raise ParameterError(f"the env_sh asset has no {cls.dataset} ({cls.name} shading)")
        return cls(asset[cls.dataset], *sun_of(asset))

    def irradiance(self, dirs) -> np.ndarray:
        """``E (..., 3)`` at unit ``dirs (..., 3)`` (radiance × sr), sun included."""
        d, flat = _flat(dirs)
        out = evaluate(self.coeffs, flat)  # fused and blocked (numpy for small jobs): sh.basis
        if self.sun_irradiance.any():
            k = self.sun_factor.py_func(flat @ self.sun_direction)
            out += k[:, None] * self.sun_irradiance
        return out.reshape(d.shape[:-1] + (3,))

    sun_factor = staticmethod(sun_lambert)
    """The sun's factor ``max(0, n·s)``."""

    def shade(self, normals, views, albedo=1.0):
        return self.irradiance(normals) * (np.asarray(albedo, dtype=np.float64) * INV_PI)


class TangentSHShader(IrradianceShader):
    """A Kajiya–Kay diffuse fibre (Mehta et al. 2012) of colour ``k_d`` under an ``env_sh``
    asset, from the tangent-irradiance SH: ``k_d E(t)``, ``E(t) = Σ_i c_i y_i(t) +
    sqrt(1 − (t·s)²)/π² E_sun`` at unit fibre ``tangents``; view-independent."""

    name = "tangent-sh"
    inputs = (
        Texture("tangent_irradiance_sh", "sh-vector", ("(lmax_irr+1)**2", 3),
                "/tangent_irradiance/sh", "tangent irradiance SH (A_l and 1/π² folded in)"),
        *SUN_INPUTS,
        Uniform("kd", "Kajiya–Kay diffuse colour k_d, RGB in [0, 1]", "material", ""),
    )  # fmt: skip
    material = {"kd": ("Kajiya–Kay diffuse colour k_d, scalar or RGB in [0, 1]", 1.0)}
    truth = "tangent"
    tangents = True
    dataset = "/tangent_irradiance/sh"
    sun_factor = staticmethod(sun_tangent)

    def shade(self, normals, views, tangents=None, kd=1.0):
        return self.irradiance(tangents) * np.asarray(kd, dtype=np.float64)


class TangentShader(Shader):
    """The Kajiya–Kay diffuse fibre of :class:`TangentSHShader` by the 4×4 matrix of
    Mehta et al. 2012 eq. 23–24, ``E(t) = t̃ᵀ M t̃`` per channel (``t̃ = (t, 1)``): what the
    preview's ``tangent`` pass draws."""

    name = "tangent"
    kinds = ("env_sh",)
    inputs = (
        Texture("tangent_irradiance_matrix", "sh-matrix", (3, 4, 4),
                "/tangent_irradiance/matrix", "Mehta et al. 2012 eq. 24, one matrix per channel"),
        *SUN_INPUTS,
        Uniform("kd", "Kajiya–Kay diffuse colour k_d, RGB in [0, 1]", "material", ""),
    )  # fmt: skip
    material = TangentSHShader.material
    truth = "tangent"
    tangents = True

    def __init__(self, matrix, sun_direction, sun_irradiance):
        self.matrix = np.ascontiguousarray(matrix, dtype=np.float64)
        self.sun_direction, self.sun_irradiance = sun_direction, sun_irradiance

    @classmethod
    def from_asset(cls, asset, **companions):
        if "/tangent_irradiance/matrix" not in asset:
            raise ParameterError("the env_sh asset has no /tangent_irradiance/matrix "
                                 "(tangent shading)")  # fmt: skip
        return cls(asset["/tangent_irradiance/matrix"], *sun_of(asset))

    def shade(self, normals, views, tangents=None, kd=1.0):
        d, flat = _flat(tangents)
        out = np.empty((flat.shape[0], 3))
        _matrix_with_sun(flat, self.matrix, self.sun_direction, self.sun_irradiance, out)
        return out.reshape(d.shape[:-1] + (3,)) * np.asarray(kd, dtype=np.float64)
