"""What the SHRM tests share (bakers, evaluation, format): a shared map box-filtered small, and
the relative RMS difference they measure."""

import numpy as np

from shbake.envmap import load_environment
from shbake.envmap.environment import Environment
from tests.helpers import map_path


def small_env(name="city", height=128):
    """A shared map box-filtered down to ``height`` rows (both sides see the same pixels)."""
    env = load_environment(str(map_path(name)), quiet=True)
    px = env.pixels.astype(np.float64)
    while px.shape[0] > height:
        px = 0.25 * (px[0::2, 0::2] + px[1::2, 0::2] + px[0::2, 1::2] + px[1::2, 1::2])
    return Environment(px.astype(np.float32), "latlong", dict(env.meta))


def rel_rms(a, b):
    """``‖a − b‖ / ‖b‖`` over every value (the relative RMS difference)."""
    return float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b**2)))
