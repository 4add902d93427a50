"""Labelled contact sheets: result | reference | signed error, with a colour bar and a title.

One PNG per preview (or evaluation case) that a person can read without the
command line that made it: the shaded result and the brute-force reference
tone-mapped with ONE exposure (:func:`shbake.format.images.tonemap`, on
luminance), and the signed luminance error divided by the reference's mean
luminance on a diverging scale symmetric about 0, its colour bar labelled.
The title names the asset, the pass and its settings; the subtitle the MSE
and the relative RMS error. Written through :mod:`shbake.format.atomic`;
matplotlib's ``Agg`` backend with no timestamp, so the same images give the
same bytes.
"""

import numpy as np

from shbake.conventions import REC709_LUMINANCE
from shbake.format.atomic import atomic_path
from shbake.format.images import auto_exposure, tonemap

BACKGROUND = (0.18, 0.18, 0.18)


def signed_relative_error(result: np.ndarray, reference: np.ndarray, mask) -> np.ndarray:
    """``(Y(result) − Y(reference)) / mean Y(reference)`` per pixel (0 outside ``mask``)."""
    y_res = np.asarray(result, float) @ REC709_LUMINANCE
    y_ref = np.asarray(reference, float) @ REC709_LUMINANCE
    mean = float(y_ref[mask].mean()) if np.any(mask) else 0.0
    err = (y_res - y_ref) / (mean if mean > 0 else 1.0)
    return np.where(mask, err, 0.0)


def _panel(ax, rgb, mask, label):
    img = np.where(mask[..., None], rgb, BACKGROUND)
    ax.imshow(img, interpolation="nearest")
    ax.set_title(label, fontsize=9)
    ax.set_axis_off()


def write_contact_sheet(
    path: str,
    result: np.ndarray,
    mask: np.ndarray,
    title: str,
    reference: np.ndarray | None = None,
    subtitle: str = "",
    labels: tuple[str, str] = ("result", "brute-force reference"),
) -> str:
    """Write the sheet for a ``(H, W, 3)`` linear ``result`` (and ``reference``) to ``path``.

    ``mask`` marks the pixels that were shaded (the sphere). Returns ``path``.
    """
    import matplotlib

    matplotlib.use("Agg", force=True)
    from matplotlib.figure import Figure

    exposure = auto_exposure(np.where(mask[..., None], reference if reference is not None
                                      else result, 0.0))  # fmt: skip
    panels = 1 if reference is None else 3
    fig = Figure(figsize=(3.2 * panels + (0.6 if reference is not None else 0.0), 3.9), dpi=100)
    axes = fig.subplots(1, panels, squeeze=False)[0]
    _panel(axes[0], tonemap(result, exposure), mask, labels[0])
    if reference is not None:
        _panel(axes[1], tonemap(reference, exposure), mask, labels[1])
        err = signed_relative_error(result, reference, mask)
        scale = float(np.max(np.abs(err[mask]))) if np.any(mask) else 0.0
        scale = scale if scale > 0 else 1.0
        shown = np.ma.masked_where(~mask, err)
        im = axes[2].imshow(shown, cmap="RdBu_r", vmin=-scale, vmax=scale,
                            interpolation="nearest")  # fmt: skip
        axes[2].set_facecolor(BACKGROUND)
        axes[2].set_title("signed error", fontsize=9)
        axes[2].set_axis_off()
        bar = fig.colorbar(im, ax=axes[2], fraction=0.046, pad=0.04)
        bar.set_label("(result − reference) / mean reference luminance", fontsize=7)
        bar.ax.tick_params(labelsize=7)
    fig.suptitle(title + ("\n" + subtitle if subtitle else ""), fontsize=9)
    fig.text(0.01, 0.01, f"exposure ×{exposure:.3g}, Reinhard on luminance, sRGB", fontsize=6)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", metadata={"Software": None})
    return path
