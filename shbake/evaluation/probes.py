"""SH-exp vs split-sum against ground truth on rendered spheres (paper §5.1).

A case is (map, material, roughness, view): a sphere of ``size²`` pixels seen
orthographically from a camera at yaw ``θ`` about +Y (view ``v`` the camera
direction), shaded three ways — ground truth (:func:`ggx_integrals`, dense
visible-normal quadrature), the SH-exp probe and the split-sum probe. Error:
mean squared error over the sphere's pixels and channels. The truth's own
error is estimated from a second truth at a quarter of the samples:
``MSE(T_{N/4} − T_N) / 5`` (each estimate's variance shrinking as ``1/N``),
so a case whose two MSEs differ by less than it is a tie in all but name.
"""

from dataclasses import dataclass

import numpy as np

from shbake.format.probe import check_probe_roughness
from shbake.preview.sphere import sphere_geometry
from shbake.reference.ggx import ggx_integrals
from shbake.shading.shexp import evaluate_shexp
from shbake.shading.splitsum import evaluate_splitsum

MATERIALS = {"chrome": 1.0, "dielectric": 0.04}
ROUGHNESS = (0.25, 0.4, 0.6, 0.8, 1.0)
VIEW_YAWS = (0.0, 90.0, 180.0, 270.0)


def sphere_views(size: int, yaw_deg: float):
    """World normals ``(P, 3)`` of the visible sphere pixels, the view ``v`` and the mask."""
    n, _, mask = sphere_geometry(size)
    a = np.radians(yaw_deg)
    R = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    normals = n[mask] @ R.T
    view = R @ np.array([0.0, 0.0, 1.0])
    # keep pixels with n·v > 0 strictly (the silhouette's last ring is grazing)
    keep = normals @ view > 1e-3
    mask2 = mask.copy()
    mask2[mask] = keep
    return normals[keep], view, mask2


@dataclass
class ProbeRenders:
    """Radiance ``(P, 3)`` per shading method for one case."""

    truth: np.ndarray
    coarse_truth: np.ndarray
    shexp: np.ndarray
    splitsum: np.ndarray

    def mse(self) -> tuple[float, float]:
        return (
            float(np.mean((self.shexp - self.truth) ** 2)),
            float(np.mean((self.splitsum - self.truth) ** 2)),
        )

    def truth_mse(self) -> float:
        """Estimated MSE of the truth itself (module docstring)."""
        return float(np.mean((self.coarse_truth - self.truth) ** 2)) / 5.0


def render_case(pixels, shexp_asset, splitsum_asset, roughness, f0, yaw, size, truth_samples):
    """Shade one case three ways; returns :class:`ProbeRenders`."""
    for asset in (shexp_asset, splitsum_asset):
        check_probe_roughness(asset, roughness)
    normals, view, _ = sphere_views(size, yaw)
    views = np.broadcast_to(view, normals.shape)
    e0, e1 = ggx_integrals(pixels, views, normals, roughness, truth_samples)
    truth = f0 * e0 + (1.0 - f0) * e1
    e0, e1 = ggx_integrals(pixels, views, normals, roughness, max(16, truth_samples // 4))
    coarse_truth = f0 * e0 + (1.0 - f0) * e1
    table = shexp_asset["/dfg"]
    shexp = evaluate_shexp(
        shexp_asset["/p"], shexp_asset["/q"], table, views, normals, roughness, (f0,) * 3
    )
    levels = [splitsum_asset[f"/levels/{k}"] for k in range(splitsum_asset.attrs["levels"])]
    split = evaluate_splitsum(
        levels, splitsum_asset["/level_roughness"], splitsum_asset["/dfg"],
        views, normals, roughness, (f0,) * 3,
    )  # fmt: skip
    return ProbeRenders(truth, coarse_truth, shexp, split)
