"""BRDF models in the local shading frame (normal +Z, tangent +X; SPEC §3) and their SH tables.

Each model module cites its paper, declares its parameters
(:class:`~shbake.brdf.spec.ModelSpec`) and provides check-free numba kernels
``evaluate`` and, for glossy models, ``sample``/``pdf`` of a lobe strategy.
"""

from shbake.brdf.model import BRDF, MODELS, make_brdf, model_spec

__all__ = ["BRDF", "MODELS", "make_brdf", "model_spec"]
