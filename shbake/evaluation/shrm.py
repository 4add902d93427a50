"""How far an SHRM's shading is from brute force of the map it was baked from.

:class:`ShrmCheck` shades the preview's sphere (:func:`shbake.preview.sphere.sphere_geometry`,
orthographic, seen from +Z) by brute force over every texel of the map, as the preview's
reference does (:func:`shbake.reference.reflection.brute_force_reflection`), and measures a
baked cube against it: the relative energy of the error, ``Σ (shaded − ref)² / Σ ref²``,
comparable with the BRDF energy the orders leave out (RH02 §5.1). The tangent kind has no
surface to shade. Used by ``shrm --report`` and the scene bake's error check.
"""

import numpy as np

from shbake.brdf.reflection import ReflectionBRDF
from shbake.evaluation.metrics import relative_error_energy
from shbake.preview.sphere import sphere_geometry
from shbake.reference.reflection import brute_force_reflection
from shbake.shading.shader import shader

VIEW = np.array([0.0, 0.0, 1.0])
"""The check sphere's view (toward the viewer, world)."""


class ShrmCheck:
    """Brute-force shading of a ``sphere``² preview sphere under ``env`` turned by
    ``rotation`` (a scene probe's pose): ``ref`` ``(N, 3)`` on the sphere's pixels, ``None``
    for the tangent kind."""

    def __init__(self, env, rb: ReflectionBRDF, sphere: int = 24, rotation=None):
        normals, _, mask = sphere_geometry(sphere)
        n = normals[mask]
        self.normals, self.view, self.kind = n, VIEW, rb.kind
        self.ref = None
        dirs, om, rad = env.samples()
        if rotation is not None:
            dirs = dirs @ np.asarray(rotation).T  # the map's d is seen at R d
        if rb.kind != "tangent":
            self.ref = brute_force_reflection(dirs, om, rad, rb.kind, rb.name,
                                              rb.describe()["parameters"], n, VIEW,
                                              source=rb.source,
                                              source_sha256=rb.source_sha256)  # fmt: skip

    def rel_energy(self, asset) -> float:
        """``Σ (shaded − ref)² / Σ ref²`` (:func:`~shbake.evaluation.metrics.
        relative_error_energy`, comparable with ``eps_brdf``) of an ``shrm`` asset, shaded
        by the registry's ``shrm`` shader."""
        img = shader(asset).shade(self.normals, np.broadcast_to(self.view, self.normals.shape))
        return relative_error_energy(img, self.ref)
