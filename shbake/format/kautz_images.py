"""Images of a BRDF table: one EXR per band, and a PNG sheet like Kautz et al. Fig. 2."""

import os

import numpy as np

from shbake.format.images import STRIP_BACKGROUND as BACKGROUND
from shbake.format.images import STRIP_GAP as GAP
from shbake.format.images import component_strip, diverging8, write_exr, write_png


def band_channel_names(l: int, coloured: bool) -> tuple[str, ...]:
    """EXR channel names of band ``l``: ``m-2 … m2`` (``.R/.G/.B`` suffixes when RGB)."""
    names = [f"m{m}" for m in range(-l, l + 1)]
    if coloured:
        return tuple(f"{n}.{c}" for n in names for c in "RGB")
    return tuple(names)


def write_band_exrs(directory: str, coeffs: np.ndarray, lmax: int, coloured: bool, suffix="",
                    png: bool = False) -> list[str]:  # fmt: skip
    """Write ``band{l}{suffix}.exr`` (float32) for ``l = 0 … lmax``; ``coeffs (H, W, n, 3)``;
    with ``png`` also ``band{l}{suffix}.png``, the band's components (channel mean) side by
    side (:func:`~shbake.format.images.component_strip`, ``p_y = +1`` at the top as in the sheet).

    Returns the paths written. Row 0 of each image is texture row 0 (``p_y = −1``).
    """
    paths = []
    for l in range(lmax + 1):
        block = coeffs[:, :, l * l : (l + 1) ** 2]
        img = block.reshape(block.shape[0], block.shape[1], -1) if coloured else block[..., 0]
        path = os.path.join(directory, f"band{l}{suffix}.exr")
        write_exr(path, img, half=False, channel_names=band_channel_names(l, coloured))
        paths.append(path)
        if png:
            paths.append(os.path.splitext(path)[0] + ".png")
            write_png(paths[-1], component_strip(block.mean(axis=-1)[::-1]))
    return paths


def sheet(coeffs: np.ndarray, lmax: int, tile: int = 128) -> np.ndarray:
    """The Fig. 2 sheet: a row of component tiles per band, then a row of band energies.

    Components are the channel mean, scaled per band by its largest magnitude;
    energies ``Σ_m c_lm²`` share one scale (square-root display), so the
    attenuation at higher bands shows. Returns ``(rows, cols, 3)`` uint8.
    """
    c = coeffs.mean(axis=-1)
    stride = max(1, int(np.ceil(c.shape[0] / tile)))
    c = c[::stride, ::stride]
    th, tw = c.shape[:2]
    ncol = 2 * lmax + 1
    out = np.full(((lmax + 2) * (th + GAP) + GAP, ncol * (tw + GAP) + GAP, 3), BACKGROUND, np.uint8)

    def put(row, col, img):
        y, x = GAP + row * (th + GAP), GAP + col * (tw + GAP)
        out[y : y + th, x : x + tw] = img[::-1]  # p_y = +1 at the top

    energy = []
    for l in range(lmax + 1):
        block = c[:, :, l * l : (l + 1) ** 2]
        scale = max(float(np.abs(block).max()), 1e-30)
        first = lmax - l
        for k in range(2 * l + 1):
            put(l, first + k, diverging8(block[:, :, k] / scale))
        energy.append((block**2).sum(axis=-1))
    top = max(float(max(e.max() for e in energy)), 1e-30)
    for l, e in enumerate(energy):
        g = np.round(255 * np.sqrt(np.clip(e / top, 0, 1))).astype(np.uint8)
        put(lmax + 1, lmax // 2 + l, np.repeat(g[..., None], 3, -1))
    return out


def write_sheet(path: str, coeffs: np.ndarray, lmax: int) -> None:
    """Write :func:`sheet` as a PNG."""
    write_png(path, sheet(coeffs, lmax))
