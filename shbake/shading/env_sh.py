"""What an engine's shader does with an ``env_sh`` asset: SH irradiance plus its lights.

Shaders (:mod:`shbake.shading.shader`): ``irradiance`` (:class:`IrradianceShader`),
``tangent`` (:class:`TangentShader`, the matrix form) and ``tangent-sh``
(:class:`TangentSHShader`).

Lambert (``/irradiance/sh``, ``Â_l`` folded in, SPEC §4)::

    E(n) = Σ_i c_i y_i(n) + Σ_k max(0, n·s_k) E_k

(a sphere light, ``/lights/angular_radius`` ``σ_k > 0``: ``max(0, n·s_k)`` becomes its
horizon-clipped :func:`~shbake.shading.sphere_light.sphere_lambert`, and
``sqrt(1 − (t·s_k)²)/π²`` its cap average :func:`~shbake.shading.sphere_light.sphere_tangent`)

Kajiya–Kay tangent irradiance (Mehta et al. 2012), from ``/tangent_irradiance/sh``
(``A_l`` folded in) or the 4×4 matrix of eq. 23–24 (``/tangent_irradiance/matrix``)::

    E(t) = Σ_i c_i y_i(t) + Σ_k sqrt(1 − (t·s_k)²)/π² E_k = t̃ᵀ M t̃ + Σ_k sqrt(1 − (t·s_k)²)/π² E_k

with ``s_k`` a light's direction and ``E_k`` its irradiance at normal incidence: the
extracted sun (``/sun``: ``E = radiance × solid_angle``) or the fitted lights
(``/lights``); none when the asset has neither.
Kernels are check-free: directions unit, arrays from a validated asset.
"""

import numpy as np

from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.basis import evaluate
from shbake.shading.shader import Shader, Texture, Uniform
from shbake.shading.sphere_light import sphere_lambert, sphere_tangent

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


@jit
def _matrix_with_lights(tangents, M, light_dirs, light_energy, out, b0, b1):
    for p in range(b0, b1):
        t = (tangents[p, 0], tangents[p, 1], tangents[p, 2], 1.0)
        for ch in range(3):
            e = 0.0
            for r in range(4):
                for s in range(4):
                    e += t[r] * M[ch, r, s] * t[s]
            out[p, ch] = e
        for j in range(light_dirs.shape[0]):
            d = light_dirs[j]
            k = sun_tangent(t[0] * d[0] + t[1] * d[1] + t[2] * d[2])
            for ch in range(3):
                out[p, ch] += k * light_energy[j, ch]


def lights_of(asset):
    """``(directions (K, 3), E (K, 3), radii (K,))`` of an ``env_sh`` asset's lights: its
    sun (``E = radiance × solid_angle``) or its fitted ``/lights``; ``radii``: sphere
    lights' angular radii in radians (``/lights/angular_radius``), 0 for points; ``K = 0``
    without."""
    if "/sun/direction" in asset:
        return (
            np.asarray(asset["/sun/direction"], float).reshape(1, 3),
            (np.asarray(asset["/sun/radiance"], float) * float(asset["/sun/solid_angle"]))[None],
            np.zeros(1),
        )
    if "/lights/direction" in asset:
        dirs = np.asarray(asset["/lights/direction"], float).reshape(-1, 3)
        radii = (np.asarray(asset["/lights/angular_radius"], float).reshape(-1)
                 if "/lights/angular_radius" in asset else np.zeros(len(dirs)))  # fmt: skip
        return dirs, np.asarray(asset["/lights/irradiance"], float).reshape(-1, 3), radii
    return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)


def _flat(dirs):
    d = np.asarray(dirs, dtype=np.float64)
    return d, np.ascontiguousarray(d.reshape(-1, 3))


LIGHT_INPUTS = (
    Uniform("light_directions", "unit vectors toward the lights (K, 3), world frame",
            "/sun/direction + /lights/direction",
            "the extracted sun or the fitted lights (K = 0: neither)"),
    Uniform("light_irradiance", "radiance × sr, RGB (K, 3)",
            "/sun/radiance × /sun/solid_angle + /lights/irradiance",
            "each light's irradiance at normal incidence E_k"),
    Uniform("light_radii", "radians (K,), [0, π/3]", "/lights/angular_radius",
            "sphere lights' angular radii σ_k (0: a point)"),
)  # fmt: skip
"""The lights (directional, or spheres) every ``env_sh`` shader adds (:func:`lights_of`)."""


class IrradianceShader(Shader):
    """A Lambert surface of albedo ``ρ`` under an ``env_sh`` asset: ``ρ E(n) / π`` with
    ``E(n) = Σ_i E_i y_i(n) + Σ_k max(0, n·s_k) E_k`` (module docstring); view-independent.

    >>> from shbake.format.asset import Asset
    >>> sky = Asset("env_sh", {}, {"/irradiance/sh": np.zeros((9, 3)),
    ...                            "/lights/direction": np.array([[0.0, 1.0, 0.0]]),
    ...                            "/lights/irradiance": np.array([[np.pi, np.pi, 0.0]])})
    >>> IrradianceShader.from_asset(sky).shade([[0.0, 1.0, 0.0]], None).tolist()  # lit head-on
    [[1.0, 1.0, 0.0]]
    """

    name = "irradiance"
    glsl = "irradiance.glsl:shbakeIrradiance"
    kinds = ("env_sh",)
    inputs = (
        Texture("irradiance_sh", "sh-vector", ("(lmax_irr+1)**2", 3), "/irradiance/sh",
                "Lambert irradiance SH E_i (Â_l folded in), radiance × sr"),
        *LIGHT_INPUTS,
        Uniform("albedo", "Lambert albedo ρ, RGB in [0, 1]", "material", "the surface's colour"),
    )  # fmt: skip
    material = {"albedo": ("Lambert albedo ρ, scalar or RGB in [0, 1]", 1.0)}
    truth = "irradiance"
    dataset = "/irradiance/sh"

    def __init__(self, coeffs, light_directions, light_irradiance, light_radii):
        self.coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)
        self.light_directions = np.ascontiguousarray(light_directions, dtype=np.float64)
        self.light_irradiance = np.ascontiguousarray(light_irradiance, dtype=np.float64)
        self.light_radii = np.ascontiguousarray(light_radii, dtype=np.float64)

    @classmethod
    def from_asset(cls, asset, **companions):
        if cls.dataset not in asset:
            raise ParameterError(f"the env_sh asset has no {cls.dataset} ({cls.name} shading)")
        return cls(asset[cls.dataset], *lights_of(asset))

    def irradiance(self, dirs) -> np.ndarray:
        """``E (..., 3)`` at unit ``dirs (..., 3)`` (radiance × sr), lights included."""
        d, flat = _flat(dirs)
        out = evaluate(self.coeffs, flat)  # fused and blocked (numpy for small jobs): sh.basis
        lights = zip(self.light_directions, self.light_irradiance, self.light_radii, strict=True)
        for direction, energy, radius in lights:
            if energy.any():
                out += self.light_factor(flat @ direction, radius)[:, None] * energy
        return out.reshape(d.shape[:-1] + (3,))

    @staticmethod
    def light_factor(c, radius):
        """A light's factor at ``c = n·s``: ``max(0, c)``, a sphere's :func:`sphere_lambert`."""
        return sphere_lambert(c, radius) if radius > 0.0 else sun_lambert.py_func(c)

    def shade(self, normals, views, albedo=1.0):
        return self.irradiance(normals) * (np.asarray(albedo, dtype=np.float64) * INV_PI)


class TangentSHShader(IrradianceShader):
    """A Kajiya–Kay diffuse fibre (Mehta et al. 2012) of colour ``k_d`` under an ``env_sh``
    asset, from the tangent-irradiance SH: ``k_d E(t)``, ``E(t) = Σ_i c_i y_i(t) +
    Σ_k sqrt(1 − (t·s_k)²)/π² E_k`` at unit fibre ``tangents``; view-independent."""

    name = "tangent-sh"
    glsl = "tangent_irradiance.glsl:shbakeTangentIrradianceSH"
    inputs = (
        Texture("tangent_irradiance_sh", "sh-vector", ("(lmax_irr+1)**2", 3),
                "/tangent_irradiance/sh", "tangent irradiance SH (A_l and 1/π² folded in)"),
        *LIGHT_INPUTS,
        Uniform("kd", "Kajiya–Kay diffuse colour k_d, RGB in [0, 1]", "material", ""),
    )  # fmt: skip
    material = {"kd": ("Kajiya–Kay diffuse colour k_d, scalar or RGB in [0, 1]", 1.0)}
    truth = "tangent"
    tangents = True
    dataset = "/tangent_irradiance/sh"

    @staticmethod
    def light_factor(c, radius):
        """A light's factor at ``c = t·s``: ``sqrt(1 − c²)/π²``, a sphere's
        :func:`~shbake.shading.sphere_light.sphere_tangent`."""
        return sphere_tangent(c, radius) if radius > 0.0 else sun_tangent.py_func(c)

    def shade(self, normals, views, tangents=None, kd=1.0):
        return self.irradiance(tangents) * np.asarray(kd, dtype=np.float64)


class TangentShader(Shader):
    """The Kajiya–Kay diffuse fibre of :class:`TangentSHShader` by the 4×4 matrix of
    Mehta et al. 2012 eq. 23–24, ``E(t) = t̃ᵀ M t̃`` per channel (``t̃ = (t, 1)``): what the
    preview's ``tangent`` pass draws."""

    name = "tangent"
    glsl = "tangent_irradiance.glsl:shbakeTangentIrradianceMatrix"
    kinds = ("env_sh",)
    inputs = (
        Texture("tangent_irradiance_matrix", "sh-matrix", (3, 4, 4),
                "/tangent_irradiance/matrix", "Mehta et al. 2012 eq. 24, one matrix per channel"),
        *LIGHT_INPUTS,
        Uniform("kd", "Kajiya–Kay diffuse colour k_d, RGB in [0, 1]", "material", ""),
    )  # fmt: skip
    material = TangentSHShader.material
    truth = "tangent"
    tangents = True

    def __init__(self, matrix, light_directions, light_irradiance, light_radii):
        self.light_radii = np.ascontiguousarray(light_radii, dtype=np.float64)
        self.matrix = np.ascontiguousarray(matrix, dtype=np.float64)
        self.light_directions = np.ascontiguousarray(light_directions, dtype=np.float64)
        self.light_irradiance = np.ascontiguousarray(light_irradiance, dtype=np.float64)

    @classmethod
    def from_asset(cls, asset, **companions):
        if "/tangent_irradiance/matrix" not in asset:
            raise ParameterError("the env_sh asset has no /tangent_irradiance/matrix "
                                 "(tangent shading)")  # fmt: skip
        return cls(asset["/tangent_irradiance/matrix"], *lights_of(asset))

    def shade(self, normals, views, tangents=None, kd=1.0):
        d, flat = _flat(tangents)
        out = np.empty((flat.shape[0], 3))
        points = self.light_radii == 0.0  # in the kernel; spheres after it
        work = flat.shape[0] * (110.0 + 20.0 * int(points.sum()))
        run_blocks(_matrix_with_lights, flat.shape[0], work, flat, self.matrix,
                   self.light_directions[points], self.light_irradiance[points], out)  # fmt: skip
        for k in np.flatnonzero(~points):
            out += (sphere_tangent(flat @ self.light_directions[k], self.light_radii[k])[:, None]
                    * self.light_irradiance[k])  # fmt: skip
        return out.reshape(d.shape[:-1] + (3,)) * np.asarray(kd, dtype=np.float64)
