"""Labelled contact sheets: result | reference | signed error, with a colour bar and a title.

One PNG per preview (or evaluation case) that a person can read without the
command line that made it: the shaded result and the brute-force reference
tone-mapped with ONE exposure and one display transform
(:func:`shbake.format.images.tonemap`: Reinhard or ACES), and the signed luminance
error divided by the reference's mean luminance on a FIXED diverging scale
(:data:`ERROR_SCALE`, the same on every sheet; pixels beyond it marked), its colour
bar labelled; under them, when given, a thumbnail of the source map. The title
names the asset, the pass and its settings; the subtitle the MSE and the
relative RMS error; the last line the exposure and display transform. Written
through :mod:`shbake.format.atomic`; matplotlib's ``Agg`` backend with no timestamp,
so the same images give the same bytes.
"""

import numpy as np

from shbake.conventions import REC709_LUMINANCE
from shbake.format.atomic import atomic_path
from shbake.format.images import auto_exposure, tonemap

BACKGROUND = (0.18, 0.18, 0.18)
ERROR_SCALE = 0.10
"""The error panel's fixed scale: ±10 % of the reference's mean luminance, the same on every
sheet so that sheets compare; pixels beyond it are drawn in :data:`BEYOND_COLOURS`."""
BEYOND_COLOURS = ("lime", "magenta")
"""Error pixels below −:data:`ERROR_SCALE` and above +:data:`ERROR_SCALE`."""
THUMBNAIL_WIDTH = 256
"""Largest width in texels of the source map's thumbnail (block means)."""
FONT_PT = 10
"""Every label's size in points (9 for tick labels): readable at the page's scale."""
TITLE_Y = 1.0
"""Panel titles at the top of their (axis-less) panels, as matplotlib's automatic placement
puts them there, given explicitly: the automatic placement measures every tick of the
hidden axes at each draw (about a quarter of a sheet's time; same bytes)."""


def signed_relative_error(result: np.ndarray, reference: np.ndarray, mask) -> np.ndarray:
    """``(Y(result) − Y(reference)) / mean Y(reference)`` per pixel (0 outside ``mask``)."""
    y_res = np.asarray(result, float) @ REC709_LUMINANCE
    y_ref = np.asarray(reference, float) @ REC709_LUMINANCE
    mean = float(y_ref[mask].mean()) if np.any(mask) else 0.0
    err = (y_res - y_ref) / (mean if mean > 0 else 1.0)
    return np.where(mask, err, 0.0)


def beyond_scale(result: np.ndarray, reference: np.ndarray, mask) -> float:
    """Fraction of the ``mask`` pixels whose :func:`signed_relative_error` lies beyond
    ±:data:`ERROR_SCALE` (the pixels the sheet marks)."""
    if not np.any(mask):
        return 0.0
    err = signed_relative_error(result, reference, mask)[mask]
    return float(np.count_nonzero(np.abs(err) > ERROR_SCALE)) / err.size


def thumbnail(pixels: np.ndarray, width: int = THUMBNAIL_WIDTH) -> np.ndarray:
    """A map ``(H, W, 3)`` shrunk by block means to at most ``width`` columns (its layout
    kept: lat-long, strip or cross), rows and columns cropped to whole blocks."""
    img = np.asarray(pixels, dtype=np.float64)
    f = max(1, -(-img.shape[1] // width))
    h, w = img.shape[0] // f * f, img.shape[1] // f * f
    if h == 0:
        return img[:1, ::f]
    return img[:h, :w].reshape(h // f, f, w // f, f, 3).mean(axis=(1, 3))


def _panel(ax, rgb, mask, label):
    img = np.where(mask[..., None], rgb, BACKGROUND)
    ax.imshow(img, interpolation="nearest")
    ax.set_title(label, fontsize=FONT_PT, y=TITLE_Y)
    ax.set_axis_off()


def write_contact_sheet(
    path: str,
    result: np.ndarray,
    mask: np.ndarray,
    title: str,
    reference: np.ndarray | None = None,
    subtitle: str = "",
    labels: tuple[str, str] = ("result", "brute-force reference"),
    display: str = "reinhard",
    source: np.ndarray | None = None,
) -> str:
    """Write the sheet for a ``(H, W, 3)`` linear ``result`` (and ``reference``) to ``path``.

    ``mask`` marks the pixels that were shaded (the sphere). ``display``: the display
    transform (:data:`shbake.format.images.DISPLAY_TRANSFORMS`). ``source``: the source
    map's linear pixels, shown shrunk (:func:`thumbnail`) under the panels at its own
    exposure. The error panel's scale is fixed (:data:`ERROR_SCALE`). Returns ``path``.
    """
    import matplotlib

    matplotlib.use("Agg", force=True)
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    exposure = auto_exposure(np.where(mask[..., None], reference if reference is not None
                                      else result, 0.0))  # fmt: skip
    panels = 1 if reference is None else 3
    rows = 1 if source is None else 2
    fig = Figure(figsize=(3.4 * panels + (0.9 if reference is not None else 0.0),
                          4.4 + (1.5 if source is not None else 0.0)), dpi=100)  # fmt: skip
    grid = fig.add_gridspec(rows, panels, height_ratios=[3.4, 1.3][:rows])
    axes = [fig.add_subplot(grid[0, k]) for k in range(panels)]
    _panel(axes[0], tonemap(result, exposure, display), mask, labels[0])
    if reference is not None:
        _panel(axes[1], tonemap(reference, exposure, display), mask, labels[1])
        err = signed_relative_error(result, reference, mask)
        cmap = colormaps["RdBu_r"].with_extremes(under=BEYOND_COLOURS[0], over=BEYOND_COLOURS[1])
        shown = np.ma.masked_where(~mask, err)
        im = axes[2].imshow(shown, cmap=cmap, vmin=-ERROR_SCALE, vmax=ERROR_SCALE,
                            interpolation="nearest")  # fmt: skip
        axes[2].set_facecolor(BACKGROUND)
        beyond = beyond_scale(result, reference, mask)
        axes[2].set_title(f"signed error ({beyond:.1%} beyond ±{ERROR_SCALE:.0%})",
                          fontsize=FONT_PT, y=TITLE_Y)  # fmt: skip
        axes[2].set_axis_off()
        bar = fig.colorbar(im, ax=axes[2], fraction=0.046, pad=0.04, extend="both",
                           ticks=np.linspace(-ERROR_SCALE, ERROR_SCALE, 5),
                           format=lambda v, _: f"{v:+.1%}")  # fmt: skip
        bar.set_label("(result − reference) / mean ref. luminance;\n"
                      f"fixed ±{ERROR_SCALE:.0%}: green below, magenta above",
                      fontsize=FONT_PT - 1)  # fmt: skip
        bar.ax.tick_params(labelsize=FONT_PT - 1)
    if source is not None:
        ax = fig.add_subplot(grid[1, :])
        ax.imshow(tonemap(thumbnail(source), None, display), interpolation="nearest")
        ax.set_title("source map (its own exposure)", fontsize=FONT_PT, y=TITLE_Y)
        ax.set_axis_off()
    shown_as = f"exposure ×{exposure:.3g}, {display} display transform, sRGB"
    fig.suptitle("\n".join(x for x in (title, subtitle, shown_as) if x), fontsize=FONT_PT)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", metadata={"Software": None})
    return path
