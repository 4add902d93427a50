"""What every probe asset shares (``docs/FORMAT.md`` §5–7): the DFG table dataset,
the roughness convention and range, the source record and the payload size.

Probes record neither a time nor a command line: a probe is a pure function of
its map and its configuration, so the same inputs give byte-identical files
wherever they are baked.
"""

import json

import numpy as np

from shbake.conventions import DFG_MU_MIN, DFG_SAMPLES, DFG_SIZE, ROUGHNESS_MIN
from shbake.errors import FormatError, ParameterError
from shbake.format.asset import Asset
from shbake.format.provenance import map_source
from shbake.format.registry import Attr, Data

ROUGHNESS_CONVENTION = "perceptual roughness r; GGX width alpha = r^2 (Burley 2012)"
DFG_ATTRS = {
    "axes": ["n_dot_v", "roughness", "A0_A1"],
    "n_dot_v_range": [DFG_MU_MIN, 1.0],
    "roughness_range": [ROUGHNESS_MIN, 1.0],
    "samples": DFG_SAMPLES,
    "meaning": "A0 = int f_DV (n.l) dl, A1 = int f_DV (1-v.h)^5 (n.l) dl; node-centred, bilinear",
}


def source_attrs(meta: dict) -> dict:
    """The provenance block of a probe from an environment's ``meta`` (FORMAT §3)."""
    return map_source(meta)


def _check_range(value):
    lo, hi = value
    if not (isinstance(lo, int | float) and isinstance(hi, int | float)
            and ROUGHNESS_MIN - 1e-9 <= lo <= hi <= 1.0 + 1e-9):  # fmt: skip
        raise FormatError(f"attribute roughness_range {value!r:.60} must be [lo, hi] with "
                          f"{ROUGHNESS_MIN} ≤ lo ≤ hi ≤ 1")  # fmt: skip


DFG_DATA = Data(
    "/dfg", (DFG_SIZE, DFG_SIZE, 2), "float32",
    "`A0`, `A1` over node-centred `n·v ∈ [1e-3, 1]` × roughness `∈ [0.02, 1]` (attributes say "
    "so); bilinear, clamped",
)  # fmt: skip
"""The DFG table every probe kind carries."""

PROBE_ATTRS = (
    Attr("technique", "str", "the technique and its paper"),
    Attr("roughness_convention", "str", "perceptual `r`, GGX `α = r²`"),
    Attr("roughness_range", "json", "`[lo, hi]` fitted; readers MUST refuse roughness outside it "
         "unless they document extrapolation (shbake's refuse it)", json_type=list, length=2),
)  # fmt: skip
"""Root attributes every probe kind shares."""


def check_roughness_range(attrs: dict) -> None:
    """The kind check shared by probes: a sane ``roughness_range``."""
    _check_range(attrs["roughness_range"])


def probe_bytes(asset: Asset, bytes_per_value: int = 4) -> int:
    """Bytes of the per-probe payload (the shared ``/dfg`` table excluded)."""
    return bytes_per_value * sum(
        int(np.prod(a.shape))
        for name, a in asset.datasets.items()
        if name not in ("/dfg", "/level_roughness")
    )


def check_probe_roughness(asset: Asset, roughness) -> float:
    """Refuse a shading roughness outside the probe's ``roughness_range``.

    Neither probe extrapolates: SH-exp was fitted on that range only and the
    split-sum chain has no level outside it.
    """
    span = asset.attrs["roughness_range"]  # a list in memory, JSON text once read back
    lo, hi = (float(x) for x in (json.loads(span) if isinstance(span, str) else span))
    r = float(roughness)
    if not (np.isfinite(r) and lo - 1e-9 <= r <= hi + 1e-9):
        raise ParameterError(
            f"roughness {r:g} is outside this probe's fitted range [{lo:g}, {hi:g}]; "
            "probes do not extrapolate (refit with --roughness-range)"
        )
    return r
