"""The one bilinear filtering rule every texture fetch uses (what a GPU sampler does).

A continuous index ``x`` along an axis of ``n`` samples (texel ``k`` at
``x = k``; for texel-centred textures ``x = u·n − ½``) is clamped to
``[0, n − 1]`` (clamp-to-edge addressing) and split into the two samples
``i0, i1`` around it and the fraction ``f``; two axes blend as
``(1 − f0)((1 − f1) t00 + f1 t01) + f0 ((1 − f1) t10 + f1 t11)``.
Check-free kernels.
"""

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
