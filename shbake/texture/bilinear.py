"""The one bilinear filtering rule every texture fetch uses (what a GPU sampler does).

A continuous index ``x`` along an axis of ``n`` samples (texel ``k`` at
``x = k``; for texel-centred textures ``x = u·n − ½``) is clamped to
``[0, n − 1]`` (clamp-to-edge addressing) and split into the two samples
``i0, i1`` around it and the fraction ``f``; two axes blend as
``(1 − f0)((1 − f1) t00 + f1 t01) + f0 ((1 − f1) t10 + f1 t11)``.
Check-free kernels.
"""

import math

from shbake.jit import jit


@jit
def axis(x, n):
    """``(i0, i1, f)`` for continuous index ``x`` on an axis of ``n ≥ 1`` samples, clamped."""
    x = min(max(x, 0.0), n - 1.0)
    i0 = min(int(x), n - 2) if n > 1 else 0
    return i0, min(i0 + 1, n - 1), x - i0


@jit
def blend(t00, t01, t10, t11, f0, f1):
    """Bilinear blend: ``f0`` along the first axis (rows), ``f1`` along the second (columns)."""
    return (1.0 - f0) * ((1.0 - f1) * t00 + f1 * t01) + f0 * ((1.0 - f1) * t10 + f1 * t11)


@jit
def bilinear_latlong(img, u, v, out):
    """``out[c]``: a lat-long map ``img (H, W, C≥3)`` at ``(u, v) ∈ [0, 1)²`` (SPEC §3),
    texel-centred bilinear, channels 0–2: rows clamp to edge, columns wrap around."""
    h, w = img.shape[0], img.shape[1]
    r0, r1, fr = axis(v * h - 0.5, h)
    x = u * w - 0.5
    xf = math.floor(x)
    c0 = int(xf) % w
    c1 = (c0 + 1) % w
    fc = x - xf
    for c in range(3):
        out[c] = blend(img[r0, c0, c], img[r0, c1, c], img[r1, c0, c], img[r1, c1, c], fr, fc)
