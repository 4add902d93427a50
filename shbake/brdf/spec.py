"""Declarations of BRDF models and their parameters (validated in Python, packed for kernels).

Every model declares its parameters once (:class:`Param`): name, whether it is
an RGB colour, default, accepted range and unit. :class:`ModelSpec` packs the
values into the flat ``float64`` vector the numba kernels read; colour
parameters take three consecutive slots.
"""

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from shbake.errors import ParameterError


@dataclass(frozen=True)
class Param:
    """One parameter of a BRDF model.

    Attributes
    ----------
    name : str
        As given on the command line (``-p name=value``).
    default : float
    lo, hi : float
        Closed range of accepted values.
    colour : bool
        An RGB reflectance: accepts ``v`` or ``r,g,b``.
    doc : str
        Meaning and unit.
    """

    name: str
    default: float
    lo: float
    hi: float
    colour: bool = False
    doc: str = ""


@dataclass(frozen=True)
class ModelSpec:
    """A BRDF model: its kernel id, parameters, citation and energy rule.

    ``energy`` names parameters whose per-channel sum must not exceed 1
    (e.g. ``("rho_d", "rho_s")``); values that break it are refused.
    """

    name: str
    model_id: int
    params: tuple[Param, ...]
    citation: str
    summary: str
    has_lobe: bool = True
    energy: tuple[str, ...] = ()
    isotropic: bool = True
    aliases: dict = field(default_factory=dict)
    """Names that set several parameters at once, e.g. ``alpha → (alpha_x, alpha_y)``."""
    check: Callable[[dict], str | None] | None = None
    """A rule across parameters: given the resolved values, the reason they are refused
    (``None``: accepted), for what per-parameter ranges cannot say."""

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        allowed = ", ".join(self.param_names + tuple(self.aliases))
        raise ParameterError(f"model {self.name!r} has no parameter {name!r} (allowed: {allowed})")

    def targets(self, name: str) -> tuple[str, ...]:
        """The parameters ``name`` sets: itself, or an alias's (``alpha → alpha_x, alpha_y``)."""
        return self.aliases.get(name, (name,))

    def check_axes(self, names) -> None:
        """Refuse parameter axes (``--vary``) that are not scalar parameters of the model (an
        alias varies its targets together) or that set a parameter another axis sets."""
        varied: set[str] = set()
        for name in names:
            for t in self.targets(name):
                if self.param(t).colour:
                    raise ParameterError(f"--vary takes scalar parameters; {name} is a colour")
                if t in varied:
                    raise ParameterError(f"--vary {name}: {t} is varied already; each "
                                         "parameter may be varied once")  # fmt: skip
            varied |= set(self.targets(name))

    def resolve(self, values: dict) -> dict:
        """Defaults filled in, aliases expanded, every value checked; ``name → (3,) or float``."""
        out = {p.name: p.default for p in self.params}
        for name, value in values.items():
            for target in self.targets(name):
                p = self.param(target)
                out[p.name] = check_value(self.name, p, value)
        for p in self.params:
            if p.colour:
                out[p.name] = np.broadcast_to(np.asarray(out[p.name], float), (3,)).copy()
            else:
                out[p.name] = float(out[p.name])
        if self.energy:
            total = sum(np.asarray(out[n]) for n in self.energy)
            if np.any(total > 1.0 + 1e-12):
                terms = " + ".join(self.energy)
                raise ParameterError(
                    f"model {self.name!r}: {terms} = {np.max(total):.4g} > 1 breaks energy "
                    "conservation"
                )
        if self.check is not None and (reason := self.check(out)) is not None:
            raise ParameterError(f"model {self.name!r}: {reason}")
        return out

    def pack(self, resolved: dict) -> np.ndarray:
        """The flat parameter vector the kernels read (colour params take 3 slots)."""
        parts = [np.atleast_1d(np.asarray(resolved[p.name], float)) for p in self.params]
        return np.ascontiguousarray(np.concatenate(parts) if parts else np.zeros(1))


def check_value(model: str, p: Param, value) -> float | np.ndarray:
    """Parse/validate one value: a float, or for colours a float or three floats."""
    if isinstance(value, str):
        try:
            value = [float(x) for x in value.split(",")]
        except ValueError:
            raise ParameterError(f"{model}: {p.name}={value!r} is not a number") from None
        value = value[0] if len(value) == 1 else value
    arr = np.asarray(value, dtype=float)
    if arr.ndim > 1 or (arr.ndim == 1 and (not p.colour or arr.shape[0] != 3)):
        shape = "a number or r,g,b" if p.colour else "a single number"
        raise ParameterError(f"{model}: {p.name} must be {shape}, got {value!r}")
    if not np.all(np.isfinite(arr)) or np.any(arr < p.lo) or np.any(arr > p.hi):
        shown = ",".join(f"{float(x):g}" for x in np.atleast_1d(arr))  # not np.float64(nan)
        raise ParameterError(
            f"{model}: {p.name}={shown} is outside [{p.lo:g}, {p.hi:g}] ({p.doc})"
        )
    return arr if arr.ndim else float(arr)
