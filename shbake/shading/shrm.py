"""Shading with a Spherical Harmonic Reflection Map (Ramamoorthi & Hanrahan 2002, §7.5).

An SHRM is a cube map ``(6, S, S, n, 3)`` of coefficients: ``n = (P+1)²``
global coefficients ``B̃_ps`` (``surface`` and ``lobe`` kinds), or ``n = P+1``
coefficients ``B_p0`` indexed by the fibre tangent (``tangent`` kind).

Per frame, for a distant viewer ``V`` (unit, from the surface toward the
eye), eq. 12 sums the dynamic reflection cube map::

    B̃(R) = Σ_{p ≤ P} Σ_s B̃_ps(R) y_ps(V)                      (surface, lobe)
    B(T)  = Σ_{p ≤ P} B_p0(T) y_p0(T·V)                          (tangent)

and each pixel reads it by a seam-correct bilinear cube fetch
(:mod:`shbake.texture.cube`) at the reflection vector ``R = 2(n·V)n − V``
(or at the tangent ``T``). :func:`evaluate_shrm` is the per-pixel form
(eq. 7) for a different ``V`` at every point: the coefficients are fetched
bilinearly at ``R`` and dotted with ``y(V)``. Reads nothing but the asset's
arrays.
"""

import numpy as np

from shbake.brdf.reflection import REPARAMETERISATIONS
from shbake.conventions import check_vectors, lmax_of, unit_vectors
from shbake.errors import ParameterError
from shbake.sh.basis import real_sh
from shbake.shading.shader import Shader, Texture, Uniform
from shbake.texture.cube import cube_directions, sample_cube

SHRM_KINDS = REPARAMETERISATIONS
"""The kinds of SHRM (one per reparameterisation of the BRDF)."""


def _terms(shrm, kind: str) -> int:
    if kind not in SHRM_KINDS:
        raise ParameterError(f"unknown SHRM kind {kind!r} (allowed: {', '.join(SHRM_KINDS)})")
    s = np.shape(shrm)
    if len(s) != 5 or s[0] != 6 or s[1] != s[2] or s[4] != 3:
        raise ParameterError(f"an SHRM has shape (6, S, S, n, 3), got {s}")
    n = s[3]
    if kind == "tangent":
        return n - 1
    try:
        return lmax_of(n)
    except ParameterError:
        raise ParameterError(f"{n} coefficients per texel is not (P+1)² for any P") from None


def reflection_cube(shrm, view, kind: str = "surface") -> np.ndarray:
    """Eq. 12: the dynamic reflection cube map ``(6, S, S, 3)`` for one view ``V``."""
    P = _terms(shrm, kind)
    v = unit_vectors(view, "view")
    if kind == "tangent":
        dirs = cube_directions(shrm.shape[1])
        x = np.clip(dirs @ v, -1.0, 1.0)
        d = np.stack([np.sqrt(1.0 - x * x), np.zeros_like(x), x], axis=-1)
        y = real_sh(d, P)[..., [p * (p + 1) for p in range(P + 1)]]  # y_p0(T·V)
        return np.einsum("fijnc,fijn->fijc", shrm, y)
    s = np.asarray(shrm)
    if s.dtype not in (np.float32, np.float64):
        s = s.astype(np.float64)
    # in the asset's precision (float32, as a GPU would), one small product per texel
    y = real_sh(v, P).astype(s.dtype)
    out = np.matmul(y, s.reshape(-1, s.shape[3], 3))
    return out.reshape(s.shape[:3] + (3,)).astype(np.float64)


def reflect(normals, view) -> np.ndarray:
    """Reflection vectors ``R = 2(n·V)n − V`` ``(..., 3)`` about one unit view ``V (3,)``;
    the normals need not be unit (``n̂ = n/|n|`` enters as ``2 (n·V) n / (n·n)``)."""
    n = check_vectors(normals, "normals")
    v = unit_vectors(view, "view")
    if v.shape != (3,):
        raise ParameterError(f"view must be one (3,) vector, got shape {v.shape}")
    r = n * (2.0 * (n @ v) / (np.square(n) @ np.ones(3)))[..., None]
    r -= v
    return r


def shade(cube, normals, view, tangents=None) -> np.ndarray:
    """Radiance ``(N, 3)``: the reflection cube of :func:`reflection_cube` read at ``R``
    (or at ``tangents`` for the tangent kind)."""
    return sample_cube(cube, reflect(normals, view) if tangents is None else tangents)


def evaluate_shrm(shrm, views, normals, kind: str = "surface", tangents=None) -> np.ndarray:
    """Eq. 7 per point: radiance ``(N, 3)`` at world ``views``/``normals`` ``(N, 3)``.

    The ``n × 3`` coefficients are fetched bilinearly at ``R`` (tangent kind:
    at ``tangents``) and dotted with ``y(V)`` (``y_p0(T·V)``).
    """
    P = _terms(shrm, kind)
    v = unit_vectors(views, "views").reshape(-1, 3)
    s = np.asarray(shrm, dtype=np.float64)
    flat = s.reshape(6, s.shape[1], s.shape[2], -1)
    if kind == "tangent":
        t = unit_vectors(tangents, "tangents").reshape(-1, 3)
        coef = sample_cube(flat, t).reshape(-1, P + 1, 3)
        x = np.clip(np.sum(t * v, axis=1), -1.0, 1.0)
        d = np.stack([np.sqrt(1.0 - x * x), np.zeros_like(x), x], axis=-1)
        y = real_sh(d, P)[:, [p * (p + 1) for p in range(P + 1)]]
    else:
        n = unit_vectors(normals, "normals").reshape(-1, 3)
        r = 2.0 * np.sum(n * v, axis=1, keepdims=True) * n - v
        coef = sample_cube(flat, r).reshape(-1, s.shape[3], 3)
        y = real_sh(v, P)
    return np.einsum("nkc,nk->nc", coef, y)


def evaluate_ggx_shrm(levels, views, normals, alpha, f0) -> np.ndarray:
    """GGX radiance ``(N, 3)`` from SHRMs of ``E0`` and ``E1`` at several widths.

    ``levels``: sequence of ``(alpha_k, shrm_E0, shrm_E1)`` sorted by
    ``alpha_k`` (GGX width, ``α = r²`` of perceptual roughness ``r``); each
    SHRM baked with Schlick ``F0 = 1`` (``E0``) and ``F0 = 0`` (``E1``). The
    result ``F0 E0 + (1 − F0) E1`` (Silvennoinen et al. 2025, eq. 6–8) is
    interpolated linearly in ``α`` between the two bracketing levels (exact
    at a baked ``α``); ``alpha`` is a scalar, ``f0`` a scalar or RGB.
    """
    if not levels:
        raise ParameterError("no GGX SHRM levels")
    alphas = np.array([lv[0] for lv in levels], dtype=float)
    a = float(alpha)
    if np.any(np.diff(alphas) <= 0):
        raise ParameterError("GGX SHRM levels must be sorted by increasing alpha")
    if not alphas[0] - 1e-9 <= a <= alphas[-1] + 1e-9:
        raise ParameterError(f"alpha {a:g} outside the baked range [{alphas[0]:g}, {alphas[-1]:g}]")
    f0 = np.broadcast_to(np.asarray(f0, dtype=float), (3,))
    k = int(np.clip(np.searchsorted(alphas, a) - 1, 0, max(len(alphas) - 2, 0)))
    picks = [(k, 1.0)]
    if len(alphas) > 1:
        t = (a - alphas[k]) / (alphas[k + 1] - alphas[k])
        t = float(np.clip(t, 0.0, 1.0))
        picks = [(k, 1.0 - t), (k + 1, t)]
    out = 0.0
    for idx, w in picks:
        if w == 0.0:
            continue
        _, s0, s1 = levels[idx]
        e0 = evaluate_shrm(s0, views, normals)
        e1 = evaluate_shrm(s1, views, normals)
        out = out + w * (f0 * e0 + (1.0 - f0) * e1)
    return out


class ShrmShader(Shader):
    """An ``shrm`` asset as an engine shades it. A distant viewer (one view for every
    point) takes what a frame does: eq. 12 builds the reflection cube for that view
    (:func:`reflection_cube`), every point reads it at ``R = 2(n·v)n − v`` (tangent kind:
    at its fibre ``tangents``) by the seam-correct cube fetch; different views per point
    take eq. 7 per point (:func:`evaluate_shrm`)."""

    name = "shrm"
    kinds = ("shrm",)
    inputs = (
        Texture("shrm", "cube-faces", (6, "S", "S", "n", 3), "/shrm",
                "B̃_ps (surface, lobe: n = (P+1)², index p(p+1)+s) or B_p0 (tangent: n = P+1)"),
        Uniform("view", "unit vector toward the viewer, world frame", "material",
                "the distant viewer V of eq. 12 (one per frame)"),
    )  # fmt: skip
    truth = "reflection"

    def __init__(self, cube, kind: str, attrs: dict | None = None):
        self.kind = kind
        self.shading_kind = "tangent" if kind == "tangent" else "surface"
        self.P = _terms(cube, self.shading_kind)
        self.cube = cube
        self.attrs = attrs or {}
        self.tangents = kind == "tangent"

    @classmethod
    def from_asset(cls, asset, **companions):
        from shbake.format.shrm import shrm_from_asset

        typed = shrm_from_asset(asset)
        return cls(typed.cube, typed.kind, typed.attrs)

    def brdf(self) -> tuple[str, dict, str]:
        """``(model, parameters, MERL source)`` of the baked BRDF (the asset's record)."""
        import json

        params = self.attrs["brdf_parameters"]
        params = params if isinstance(params, dict) else json.loads(params)
        return self.attrs["brdf_model"], params, self.attrs.get("brdf_source") or ""

    def update(self, view) -> np.ndarray:
        """Eq. 12: the reflection cube ``(6, S, S, 3)`` for the distant viewer ``view``."""
        return reflection_cube(self.cube, view, self.shading_kind)

    def shade(self, normals, views, tangents=None):
        v = np.asarray(views, dtype=np.float64)
        if v.ndim == 1 or np.all(v == v.reshape(-1, 3)[0]):
            view = v.reshape(-1, 3)[0]
            return shade(self.update(view), normals, view, tangents if self.tangents else None)
        return evaluate_shrm(self.cube, v, normals, self.shading_kind, tangents)

    def modes(self, normals, views, tangents=None):
        """``frame`` (eq. 12 and the lookup) and ``eq12`` (the reflection-cube update alone,
        what a view change costs; its result is the cube, not radiance)."""
        view = np.asarray(views, dtype=np.float64).reshape(-1, 3)[0]
        return {"frame": lambda: self.shade(normals, views, tangents),
                "eq12": lambda: self.update(view)}  # fmt: skip

    def label(self) -> str:
        model, F = self.attrs.get("brdf_model", "?"), self.attrs.get("F", "?")
        return f"{model} F {F} P {self.P}, face {self.cube.shape[1]}"


class GgxShrmShader(Shader):
    """GGX from ``E0``/``E1`` SHRMs at several widths (:func:`evaluate_ggx_shrm`, per-point
    eq. 7): ``levels`` of ``(α_k, shrm_E0, shrm_E1)``; shades ``α`` within the levels'
    range. Made from baked cubes (``probe-eval``), not from an asset."""

    name = "ggx-shrm"
    kinds = ()
    inputs = (
        Texture("shrm_e0", "cube-faces", (6, "S", "S", "(P+1)**2", 3), "baked",
                "the E0 SHRM (Schlick F0 = 1) of each level"),
        Texture("shrm_e1", "cube-faces", (6, "S", "S", "(P+1)**2", 3), "baked",
                "the E1 SHRM (F0 = 0) of each level"),
        Uniform("level_alpha", "GGX width α (SPEC §1)", "baked", "the levels' widths"),
    )  # fmt: skip
    material = {"alpha": ("GGX width α within the levels", None), "f0": ("Schlick F0", 1.0)}
    truth = "ggx"
    min_nv = 1e-3

    def __init__(self, levels):
        self.levels = levels
        self.alphas = np.array([lv[0] for lv in levels], dtype=float)

    def check(self, alpha=None, f0=1.0) -> dict:
        a = float(alpha)
        if not self.alphas[0] - 1e-9 <= a <= self.alphas[-1] + 1e-9:
            raise ParameterError(f"alpha {a:g} is not within the SHRM levels "
                                 f"[{self.alphas[0]:g}, {self.alphas[-1]:g}]")  # fmt: skip
        return {"alpha": a, "f0": f0}

    def shade(self, normals, views, alpha=None, f0=1.0):
        return evaluate_ggx_shrm(self.levels, views, normals, alpha, f0)
