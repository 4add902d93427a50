"""What every probe asset shares (``docs/FORMAT.md`` §5–7): the DFG table dataset,
the roughness convention and range, the source record and the payload size.

Probes record neither a time nor a command line: a probe is a pure function of
its map and its configuration, so the same inputs give byte-identical files
wherever they are baked.
"""

import json

import numpy as np

from shbake.conventions import DFG_MU_MIN, DFG_SAMPLES, ROUGHNESS_MIN
from shbake.errors import ParameterError
from shbake.format.asset import Asset

ROUGHNESS_CONVENTION = "perceptual roughness r; GGX width alpha = r^2 (Burley 2012)"
DFG_ATTRS = {
    "axes": ["n_dot_v", "roughness", "A0_A1"],
    "n_dot_v_range": [DFG_MU_MIN, 1.0],
    "roughness_range": [ROUGHNESS_MIN, 1.0],
    "samples": DFG_SAMPLES,
    "meaning": "A0 = int f_DV (n.l) dl, A1 = int f_DV (1-v.h)^5 (n.l) dl; node-centred, bilinear",
}


def source_attrs(meta: dict) -> dict:
    """The ``source_*`` attributes of a probe from an environment's ``meta``."""
    keep = ("sha256", "width", "height", "layout", "colorspace", "negative_policy")
    return {f"source_{k}": meta[k] for k in keep if k in meta} | {
        "source_name": str(meta.get("path", "")).rsplit("/", 1)[-1]
    }


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
