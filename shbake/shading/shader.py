"""The shader protocol: one object per technique says how a renderer shades an asset.

A shader is the CPU twin of a GPU shader (the GLSL files of ``shbake/shaders/`` name the
same inputs). Each technique's module in :mod:`shbake.shading` defines one subclass of
:class:`Shader`, named in the registry :data:`SHADERS` under its technique name:

``from_asset(asset, **companions)``
    build it from a validated asset (and companion assets, e.g. the Kautz table);
``shade(normals, views, **material) -> radiance``
    outgoing radiance ``(N, 3)`` toward ``views`` at world unit ``normals`` (``(N, 3)``;
    ``tangents=`` for the Kajiya–Kay shaders), for the material parameters it names in
    :attr:`Shader.material` (units there);
``inputs``
    the textures (:class:`Texture`, with their layout, :data:`LAYOUTS`) and uniforms
    (:class:`Uniform`, with units) it reads, and where each comes from in the asset: what
    an exporter writes and what a GLSL file declares;
``modes(normals, views, **material)``
    the per-frame work of each update regime, as callables (the preview times them):
    ``{"frame": …}`` by default; the Kautz shader adds fixed light and fixed view, the
    SHRM the eq. 12 reflection-cube update;
``truth``
    the name of the brute-force integral it approximates (:mod:`shbake.reference.truth`);
``glsl``
    its GPU twin, ``file:function`` in ``shbake/shaders/`` (``docs/SHADERS.md``), which
    ``export --to webgl`` ships with the asset.

The preview, the evaluation, ``probe-eval`` and the scene bake's error checks reach the
shaders through :func:`shader` and :data:`SHADERS` only (``tests/system/test_architecture.py``).
"""

from dataclasses import dataclass
from typing import ClassVar

from shbake.errors import ParameterError

LAYOUTS = {
    "sh-vector": "SH coefficients, rows i = l(l+1)+m, RGB columns (SPEC §2)",
    "sh-matrix": "one 4×4 symmetric matrix per channel (Mehta et al. 2012 eq. 24), (3, 4, 4)",
    "parabolic": "parabolic map of the view hemisphere (Heidrich–Seidel 1999), texel centres",
    "cube-faces": "six faces +X, −X, +Y, −Y, +Z, −Z of OpenEXR envmap=cube, texel cells",
    "octahedral": "octahedral map of the sphere (shbake.texture.octahedral), texel centres",
    "lat-long": "equirectangular, row 0 is +Y (SPEC §3), texel cells",
    "dfg-lut": "DFG table over (n·v, sqrt(α)), node-centred, bilinear (shbake.shading.dfg)",
}
"""Texture layouts a shader reads (the names :class:`Texture` uses)."""


@dataclass(frozen=True)
class Texture:
    """A texture a shader samples: its ``name`` (the GLSL sampler's), ``layout`` (one of
    :data:`LAYOUTS`), ``shape`` (symbolic, as the format registry writes it), the asset
    dataset it comes from (``source``) and what it holds (``doc``)."""

    name: str
    layout: str
    shape: tuple
    source: str
    doc: str

    def __post_init__(self):
        if self.layout not in LAYOUTS:
            raise ValueError(f"unknown texture layout {self.layout!r}")


@dataclass(frozen=True)
class Uniform:
    """A uniform a shader reads: its ``name`` (the GLSL uniform's), ``units``, where it
    comes from (an asset dataset or attribute, or ``material``: given per draw) and
    ``doc``."""

    name: str
    units: str
    source: str
    doc: str


class Shader:
    """Base of every shader (module docstring): a technique ``name``, the asset ``kinds``
    it reads (the first one :meth:`from_asset` takes, then its companions), its
    ``inputs``, the ``material`` parameters :meth:`shade` takes (name → units and default),
    its ``truth``, whether it shades fibre ``tangents`` and the grazing limit ``min_nv``."""

    name: ClassVar[str]
    kinds: ClassVar[tuple[str, ...]]
    inputs: ClassVar[tuple]
    material: ClassVar[dict] = {}
    truth: ClassVar[str]
    glsl: ClassVar[str] = ""
    """The GLSL function this shader twins, ``file:function`` of ``shbake/shaders/``
    (``""``: none)."""
    tangents: ClassVar[bool] = False
    min_nv: ClassVar[float | None] = None
    """Points with ``n·v`` at or below this are left unshaded (glossy lobes at grazing)."""
    point_coeffs: int = 0
    """SH coefficients :meth:`modes` holds per point (float64 RGB; memory estimates)."""

    @classmethod
    def from_asset(cls, asset, **companions) -> "Shader":
        raise NotImplementedError

    def shade(self, normals, views, **material):
        raise NotImplementedError

    def check(self, **material) -> dict:
        """``material`` checked (a :class:`~shbake.errors.ParameterError` names the first bad
        value, e.g. a probe's ``alpha`` outside its range), as :meth:`shade` takes it."""
        return material

    def covers(self, **material) -> bool:
        """Whether :meth:`shade` accepts ``material`` (:meth:`check` passes)."""
        try:
            self.check(**material)
        except ParameterError:
            return False
        return True

    def modes(self, normals, views, **material) -> dict:
        """Per-frame work per update regime: name → callable returning the radiance."""
        return {"frame": lambda: self.shade(normals, views, **material)}

    def label(self) -> str:
        """A short description for titles (orders, sizes, the table)."""
        return self.name


SHADERS = {
    "irradiance": "env_sh:IrradianceShader",
    "tangent": "env_sh:TangentShader",
    "tangent-sh": "env_sh:TangentSHShader",
    "kautz": "brdf_table:KautzShader",
    "shexp": "shexp:ShexpShader",
    "splitsum": "splitsum:SplitsumShader",
    "shrm": "shrm:ShrmShader",
    "ggx-shrm": "shrm:GgxShrmShader",
}
"""The registry: technique name → ``module:Class`` in :mod:`shbake.shading`, imported on
first use (:func:`shader_class`), so asking for one shader loads one module. A shader
without asset kinds (``ggx-shrm``) is made from baked arrays, not from an asset."""
DEFAULT_OF_KIND = {
    "env_sh": "irradiance",
    "shexp_probe": "shexp",
    "splitsum_probe": "splitsum",
    "shrm": "shrm",
}
"""Asset kind → the technique a renderer uses for it by default."""


def shader_class(name: str) -> type[Shader]:
    """The class of technique ``name`` (:data:`SHADERS`), its module imported."""
    import importlib

    module, cls = SHADERS[name].split(":")
    return getattr(importlib.import_module(f"shbake.shading.{module}"), cls)


def shader_classes() -> dict[str, type[Shader]]:
    """Every technique's class (all of :data:`SHADERS` imported)."""
    return {name: shader_class(name) for name in SHADERS}


def shaders_of_kind(kind: str) -> tuple[str, ...]:
    """The techniques that shade an asset of ``kind`` (the default first)."""
    names = [n for n, c in shader_classes().items() if c.kinds[:1] == (kind,)]
    default = DEFAULT_OF_KIND.get(kind)
    return tuple(sorted(names, key=lambda n: n != default))


def shader(asset, name: str | None = None, **companions) -> Shader:
    """The shader ``name`` (default: its kind's, :data:`DEFAULT_OF_KIND`) built from
    ``asset`` and ``companions``; a :class:`~shbake.errors.ParameterError` names the
    techniques of the asset's kind when ``name`` is not one of them.

    >>> import numpy as np
    >>> from shbake.format.asset import Asset
    >>> sky = Asset("env_sh", {}, {"/irradiance/sh": np.array([[np.sqrt(4 * np.pi) * np.pi] * 3]
    ...                                                         + [[0.0] * 3] * 8)})
    >>> shader(sky).shade([[0.0, 1.0, 0.0]], [[0.0, 0.0, 1.0]]).round(12).tolist()  # white dome
    [[1.0, 1.0, 1.0]]
    """
    name = name or DEFAULT_OF_KIND.get(asset.kind)
    cls = shader_class(name) if name in SHADERS else None
    if cls is None or cls.kinds[:1] != (asset.kind,):
        raise ParameterError(
            f"a {asset.kind} asset is shaded by {', '.join(shaders_of_kind(asset.kind)) or 'no'}"
            f" technique; not {name!r}"
        )
    return cls.from_asset(asset, **companions)
