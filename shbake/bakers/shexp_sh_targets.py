"""The fit's ``E0`` targets from SH lighting and GGX BRDF tables (the fast path).

Instead of integrating the map at every target (:class:`QuadraturePlan`),
``E0(v, n, r) = Σ_i c_i(v_n; r) L_i^(n)`` (Kautz et al. 2002, §4: rotate,
look up, dot): ``L`` the map's SH coefficients up to ``lmax``
(:func:`shbake.sh.projection.project_latlong`), ``L^(n)`` rotated into the
frame ``(t, b, n)`` of each fit normal, and ``c(v; r)`` the parabolic-map
table of the Fresnel-free GGX (``F0 = 1``, width ``α``) at each fit
width (:func:`shbake.brdf.tabulate.tabulate`), read bilinearly at the
local view ``v_n``. Tables and frames are built once per configuration.

The cost is one projection and ``T`` dot products of ``(lmax+1)²`` terms;
the error is SH truncation: the lighting is band-limited to ``lmax`` while a
GGX lobe of width ``r²`` needs bands up to about ``2/r²``, so sharp
roughness is blurred and bright suns ring (targets can come out
negative; the fit's floor catches them). ``docs/BENCHMARKS.md`` reports the
error against the quadrature ground truth.
"""

import numpy as np

from shbake.brdf import make_brdf
from shbake.brdf.sampling import tangent_frame
from shbake.brdf.tabulate import tabulate
from shbake.conventions import SH_TARGETS_LMAX_LIMIT
from shbake.errors import ParameterError
from shbake.jit import jit, run_blocks
from shbake.sh.projection import project_latlong
from shbake.sh.rotation import rotate
from shbake.texture.parabolic import fetch_into

TABLE_RESOLUTION = (32, 32)


@jit
def _dot_targets(tables, table_of, normal_of, local_views, lighting, out, b0, b1):
    n = tables.shape[3]
    for t in range(b0, b1):
        c = np.empty((n, 1))
        fetch_into(tables[table_of[t]], local_views[t, 0], local_views[t, 1], local_views[t, 2], c)
        for ch in range(3):
            s = 0.0
            for i in range(n):
                s += c[i, 0] * lighting[normal_of[t], i, ch]
            out[t, ch] = s


class ShTargets:
    """``E0`` at fixed ``(v, n, r)`` targets by SH lighting × GGX tables.

    Parameters
    ----------
    views, normals : (T, 3) world directions; ``normals`` repeat a small set.
    roughness : (T,) GGX width ``α``, a small set of values.
    lmax : lighting bands (1–24).
    samples : integration samples per table view (:func:`tabulate`).
    """

    def __init__(self, views, normals, roughness, lmax: int = 8, samples: int = 1024):
        if not 1 <= lmax <= SH_TARGETS_LMAX_LIMIT:
            raise ParameterError(
                f"SH target lmax must be in [1, {SH_TARGETS_LMAX_LIMIT}], got {lmax}"
            )
        self.lmax = lmax
        r_values, table_of = np.unique(np.asarray(roughness, float), return_inverse=True)
        n_values, normal_of = np.unique(np.asarray(normals, float), axis=0, return_inverse=True)
        self.frames = np.array([np.array([*tangent_frame(*n), n]) for n in n_values])
        self.local_views = np.einsum("tij,tj->ti", self.frames[normal_of], views)
        self.table_of = table_of.astype(np.int64).reshape(-1)
        self.normal_of = normal_of.astype(np.int64).reshape(-1)
        self.tables = np.stack(
            [
                tabulate(make_brdf("ggx", F0=1.0, alpha=float(r)), lmax,
                         TABLE_RESOLUTION, samples)[0][..., :1]
                for r in r_values
            ]
        )  # fmt: skip

    def e0(self, pixels) -> np.ndarray:
        """``E0`` at the targets, ``(T, 3)``, from a lat-long map."""
        coeffs = project_latlong(pixels, self.lmax)
        lighting = np.stack([rotate(coeffs, frame) for frame in self.frames])
        out = np.empty((self.local_views.shape[0], 3))
        run_blocks(_dot_targets, out.shape[0], out.shape[0] * lighting.shape[1] * 12.0,
                   self.tables, self.table_of, self.normal_of, self.local_views,
                   np.ascontiguousarray(lighting), out)  # fmt: skip
        return out
