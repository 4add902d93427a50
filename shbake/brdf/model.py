"""The registry of BRDF models and :class:`BRDF`, a model with validated parameters."""

from dataclasses import dataclass, field

import numpy as np

from shbake.brdf import (
    ashikhmin_shirley,
    blinn_phong,
    ggx,
    kajiya_kay,
    lafortune,
    lambert,
    merl,
    microfacet,
    phong,
    ward,
)
from shbake.brdf.dispatch import brdf_eval
from shbake.brdf.spec import ModelSpec
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.resources import check_digest

MODELS: dict[str, ModelSpec] = {
    m.SPEC.name: m.SPEC
    for m in (
        lambert, phong, blinn_phong, ashikhmin_shirley, ward, ggx, kajiya_kay, merl,
        microfacet, lafortune,
    )
}
"""Model name → :class:`~shbake.brdf.spec.ModelSpec`, in kernel-id order."""

NO_DATA = np.zeros((3, 2, 2, 2))


@jit
def _eval_many(model, prm, data, s, v, out, b0, b1):
    f = np.empty(3)  # not a view out[i] per point: its reference counting cost 5 ns a point
    for i in range(b0, b1):
        if s[i, 2] > 0.0 and v[i, 2] > 0.0:
            brdf_eval(model, prm, data, s[i, 0], s[i, 1], s[i, 2], v[i, 0], v[i, 1], v[i, 2], f)
            out[i, 0], out[i, 1], out[i, 2] = f[0], f[1], f[2]


@dataclass
class BRDF:
    """A BRDF model with its parameters resolved and checked.

    Attributes
    ----------
    spec : ModelSpec
    values : dict
        Parameter name → float or ``(3,)`` RGB array.
    data : ndarray
        Measured data (MERL) or a placeholder.
    source : str
        Where measured data came from (path), else ``""``.
    source_sha256 : str
        Hex SHA-256 of the bytes ``data`` was decoded from, else ``""``.
    """

    spec: ModelSpec
    values: dict
    data: np.ndarray = field(default_factory=lambda: NO_DATA)
    source: str = ""
    source_sha256: str = ""

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def packed(self) -> np.ndarray:
        return self.spec.pack(self.values)

    @property
    def coloured(self) -> bool:
        """True when any colour parameter differs between channels (RGB table)."""
        if self.spec.name == "merl":
            return True
        return any(p.colour and np.ptp(self.values[p.name]) > 0 for p in self.spec.params)

    def with_values(self, **changes) -> "BRDF":
        """A copy with some parameters changed (validated)."""
        given = {k: v for k, v in self.values.items()}
        given.update(changes)
        return BRDF(self.spec, self.spec.resolve(given), self.data, self.source,
                    self.source_sha256)  # fmt: skip

    def evaluate(self, s, v) -> np.ndarray:
        """``f(s, v)`` per channel (1/sr) at local unit directions ``(..., 3)``; 0 below horizon."""
        s = np.asarray(s, dtype=float)
        v = np.broadcast_to(np.asarray(v, dtype=float), s.shape)
        flat_s = np.ascontiguousarray(s.reshape(-1, 3))
        flat_v = np.ascontiguousarray(v.reshape(-1, 3))
        out = np.zeros((flat_s.shape[0], 3))
        run_blocks(_eval_many, flat_s.shape[0], flat_s.shape[0] * 100.0,
                   self.spec.model_id, self.packed, self.data, flat_s, flat_v, out)  # fmt: skip
        return out.reshape(s.shape[:-1] + (3,))

    def describe(self) -> dict:
        """Model name and parameter values, JSON-ready."""
        vals = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.values.items()}
        return {"model": self.name, "parameters": vals, "source": self.source}


def model_spec(name: str) -> ModelSpec:
    """The spec of model ``name``; unknown names list the allowed ones."""
    try:
        return MODELS[name]
    except KeyError:
        raise ParameterError(
            f"unknown BRDF model {name!r} (allowed: {', '.join(MODELS)})"
        ) from None


def make_brdf(name: str, merl_path: str | None = None, merl_sha256: str | None = None,
               **values) -> BRDF:  # fmt: skip
    """Build a :class:`BRDF` from a model name and parameter values (strings or numbers).

    ``merl_path`` is required for (and only accepted by) the ``merl`` model;
    ``merl_sha256``, the digest an asset records of its MERL file, refuses a file whose
    bytes read differ (:func:`shbake.resources.check_digest`, a
    :class:`~shbake.errors.FormatError`).
    """
    spec = model_spec(name)
    if (name == "merl") != (merl_path is not None):
        raise ParameterError(
            "the merl model needs a MERL .binary file"
            if name == "merl"
            else f"a MERL file is only used by the merl model, not {name!r}"
        )
    if merl_path is None:
        return BRDF(spec, spec.resolve(values))
    data, digest = merl.read_merl(merl_path)
    if merl_sha256 is not None:
        check_digest(merl_path, digest, merl_sha256, "MERL file")
    return BRDF(spec, spec.resolve(values), data, str(merl_path), digest)
