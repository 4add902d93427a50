"""SH-exp vs split-sum against ground truth on rendered spheres (paper §5.1).

A case is (map, material, α, view): a sphere of ``size²`` pixels seen
orthographically from a camera at yaw ``θ`` about +Y (view ``v`` the camera
direction), shaded by every probe under test and by the ground truth
(:func:`ggx_integrals`, MIS). Error: mean squared error over the sphere's
pixels and channels. The truth's own error is estimated from a second truth
at a quarter of the samples: ``MSE(T_{N/4} − T_N) / 5`` (each estimate's
variance shrinking as ``1/N``), so a case whose two MSEs differ by less than
it is a tie in all but name.

The paper's test values (§5.1, Fig. 4–5): ``α ∈ [0.25, 1]`` "distributed
according to a perceptual roughness remapping" (Burley 2012): ``α = r²`` for
``r = 0.5, 0.6, …, 1.0`` evenly spaced, end points included — six widths
(:data:`ALPHAS`); with 8 maps, 2 materials and 2 views that is the paper's
192 cases. shbake uses 4 views and the 6 shared maps (288 cases).
"""

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from shbake.conventions import REC709_LUMINANCE, ggx_alpha
from shbake.evaluation.metrics import mean_squared_error, relative_rms_error
from shbake.format.asset import Asset
from shbake.preview.contact_sheet import write_contact_sheet
from shbake.preview.sphere import sphere_geometry
from shbake.reference.ggx import ggx_integrals
from shbake.reference.truth import ggx_truth
from shbake.shading.shader import shader

MATERIALS = {"chrome": 1.0, "dielectric": 0.04}
ALPHAS = tuple(round(ggx_alpha(r), 6) for r in (0.5, 0.6, 0.7, 0.8, 0.9, 1.0))
VIEW_YAWS = (0.0, 90.0, 180.0, 270.0)
HEADLINE_SIZE = 16
"""Sphere size (pixels per side) of a probe's headline error (:func:`glossy_error`)."""
HEADLINE_SAMPLES = 128
"""Samples per pixel of the headline's ground truth (MIS, :func:`ggx_integrals`). At 16²
pixels and 128 samples the headline is within 7 % of itself at 32² and 4096 samples on the
six sample maps (−4.6 % studio … +6.9 % forest; at 20²: −10.0 % night … +3.5 % forest) for
about 10 ms of CPU per probe, a third of what the fit costs; fewer samples are far worse
(96 at 16²: +34 % city; 64: +24 % forest; 15² with 128: −14 % night)."""


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


def probe_shaders(probes: dict) -> dict:
    """Name → shader of each probe under test: an asset (``shexp_probe``,
    ``splitsum_probe``) through the registry (:func:`shbake.shading.shader.shader`), any
    other object as it is (one with the shader protocol's ``covers`` and ``shade``, such as
    the GGX SHRM probe of ``probe-eval``)."""
    return {name: shader(p) if isinstance(p, Asset) else p for name, p in probes.items()}


@dataclass
class CaseTruth:
    """Ground truth ``E0``, ``E1`` of one (α, view) on the sphere, and a coarse pair."""

    normals: np.ndarray
    views: np.ndarray
    e0: np.ndarray
    e1: np.ndarray
    coarse_e0: np.ndarray
    coarse_e1: np.ndarray

    def radiance(self, f0: float, coarse: bool = False) -> np.ndarray:
        e0, e1 = (self.coarse_e0, self.coarse_e1) if coarse else (self.e0, self.e1)
        return f0 * e0 + (1.0 - f0) * e1


def case_truth(pixels, alpha: float, yaw: float, size: int, truth_samples: int,
               cache_dir=None) -> CaseTruth:  # fmt: skip
    """The truth of every material at one (α, view): ``E0``, ``E1`` once.

    ``cache_dir``: keep the integrals there as ``.npy`` files named by a SHA-256 of the
    map's pixels and the case (the truth does not depend on the probes under test)."""
    normals, view, _ = sphere_views(size, yaw)
    views = np.ascontiguousarray(np.broadcast_to(view, normals.shape))
    path = None
    if cache_dir is not None:
        key = hashlib.sha256(np.ascontiguousarray(pixels, np.float32).tobytes())
        key.update(repr((float(alpha), float(yaw), int(size), int(truth_samples))).encode())
        path = Path(cache_dir) / f"truth-{key.hexdigest()[:32]}.npy"
        if path.exists():
            e0, e1, c0, c1 = np.load(path)
            return CaseTruth(normals, views, e0, e1, c0, c1)
    e0, e1 = ggx_integrals(pixels, views, normals, alpha, truth_samples)
    c0, c1 = ggx_integrals(pixels, views, normals, alpha, max(16, truth_samples // 4))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npy")
        np.save(tmp, np.stack([e0, e1, c0, c1]))
        tmp.replace(path)
    return CaseTruth(normals, views, e0, e1, c0, c1)


def write_case_sheet(sheet_dir, label: str, material: str, alpha: float, yaw: float,
                     size: int, shaded: dict, ref: np.ndarray, mse: dict) -> str:  # fmt: skip
    """A labelled contact sheet of one case: the first probe of ``shaded`` (name → radiance
    ``(P, 3)`` on the visible sphere pixels) | the ground truth | the signed error; the
    title names the case, the subtitle every probe's MSE."""
    _, _, mask = sphere_views(size, yaw)
    name = next(iter(shaded))

    def image(values):
        img = np.zeros((size, size, 3))
        img[mask] = values
        return img

    title = f"{label}: {material}, α {alpha:.4g}, view yaw {yaw:.0f}°; result = {name}"
    subtitle = "MSE " + ", ".join(f"{k} {v:.3g}" for k, v in mse.items() if v is not None)
    path = str(Path(sheet_dir) / f"{label}-{material}-a{alpha:.4g}-yaw{yaw:.0f}-sheet.png")
    return write_contact_sheet(path, image(shaded[name]), mask, title, image(ref), subtitle,
                               labels=(name, "ground truth (MIS)"))  # fmt: skip


def evaluate_cases(pixels, assets: dict, size: int = 32, truth_samples: int = 4096,
                   alphas=ALPHAS, yaws=VIEW_YAWS, materials=MATERIALS,
                   cache_dir=None, sheet_dir=None, label: str = "map") -> list[dict]:  # fmt: skip
    """Rows ``{material, alpha, yaw, mse: {name: MSE}, mse_truth_estimate}`` for every case
    of one map (:func:`~shbake.evaluation.metrics.mean_squared_error` over the sphere's
    pixels and channels); ``assets``: name → probe asset or shader (:func:`probe_shaders`);
    a probe that does not cover ``α`` gets MSE ``None``; ``cache_dir``: :func:`case_truth`;
    ``sheet_dir``: also write one contact sheet per case (:func:`write_case_sheet`)."""
    shaders = probe_shaders(assets)
    rows = []
    for a in alphas:
        for yaw in yaws:
            truth = case_truth(pixels, a, yaw, size, truth_samples, cache_dir)
            for material, f0 in materials.items():
                ref = truth.radiance(f0)
                shaded = {name: sh.shade(truth.normals, truth.views, alpha=a, f0=f0)
                          for name, sh in shaders.items() if sh.covers(alpha=a)}  # fmt: skip
                mse = {name: None for name in shaders}
                mse.update({name: mean_squared_error(s, ref) for name, s in shaded.items()})
                err = mean_squared_error(truth.radiance(f0, coarse=True), ref) / 5.0
                rows.append({"material": material, "alpha": float(a), "yaw": float(yaw),
                             "mse": mse, "mse_truth_estimate": err})  # fmt: skip
                if sheet_dir is not None:
                    write_case_sheet(sheet_dir, label, material, a, yaw, size, shaded, ref, mse)
    return rows


def glossy_error(asset: Asset, env, rotation=None, size: int = HEADLINE_SIZE,
                 samples: int = HEADLINE_SAMPLES) -> dict:  # fmt: skip
    """The headline error of a glossy probe: what an engine shades from it against brute
    force. ``E0`` (F0 = 1, the lobe alone) shaded by the probe's registry shader on a
    ``size``² sphere seen from +Z (pixels with ``n·v > 10⁻³``) at the ends and the middle of
    its ``alpha_range``, against :func:`~shbake.reference.truth.ggx_truth` of the lat-long
    environment ``env`` (``samples`` per pixel; ``rotation``: the map seen turned, a scene
    probe's pose); the relative RMS of luminance over all three (``value``) and each
    (``by_alpha``)."""
    sh = shader(asset)
    lo, hi = (float(a) for a in asset.attrs["alpha_range"])
    normals, view, _ = sphere_views(size, 0.0)
    views = np.ascontiguousarray(np.broadcast_to(view, normals.shape))
    alphas = (lo, 0.5 * (lo + hi), hi)
    # one brute-force call for all three widths: the map's sampling tables are built once
    ref = ggx_truth(None, env, np.tile(normals, (3, 1)), np.tile(views, (3, 1)), rotation=rotation,
                    alpha=np.repeat(alphas, len(normals)), f0=1.0,
                    samples=samples) @ REC709_LUMINANCE  # fmt: skip
    ref = ref.reshape(3, -1)
    got = np.stack([sh.shade(normals, views, **sh.check(alpha=a, f0=1.0)) @ REC709_LUMINANCE
                    for a in alphas])  # fmt: skip
    by_alpha = [{"alpha": a, "relative_rms": relative_rms_error(g, r)}
                for a, g, r in zip(alphas, got, ref, strict=True)]  # fmt: skip
    return {"quantity": "glossy E0 (F0 = 1) an engine shades from the probe, over its α range",
            "value": relative_rms_error(got.reshape(-1), ref.reshape(-1)),
            "by_alpha": by_alpha}  # fmt: skip
