"""SH windows (:mod:`shbake.sh.windows`): Hann and Lanczos values, and the de-ringing window
checked non-negative on a fine lat-long grid.
"""

import numpy as np
import pytest

from shbake.sh.kernels import convolve, lambert_kernel
from shbake.sh.windows import dering_window, reconstruction_minimum, window


class TestWindows:
    def test_values(self):
        np.testing.assert_allclose(
            window("hann", 3),
            [1, (1 + np.cos(np.pi / 4)) / 2, 0.5, (1 + np.cos(3 * np.pi / 4)) / 2],
        )
        np.testing.assert_allclose(window("lanczos", 1), [1, np.sin(np.pi / 2) / (np.pi / 2)])
        np.testing.assert_allclose(window("none", 2), 1)

    def test_dering_makes_irradiance_non_negative(self):
        # A narrow bright lobe at +Z: plain lmax-2 irradiance rings below zero on the far side.
        from shbake.sh.basis import real_sh

        c = real_sh([0.0, 0.0, 1.0], 2)[:, None] * 50.0
        c[0] += 0.05
        K = lambert_kernel(2)
        raw_min, _ = reconstruction_minimum(convolve(c, K))
        assert raw_min < 0
        w, m = dering_window(c, [K])
        assert m >= 0
        assert w[0] == 1.0 and 0 < w[2] < w[1] < 1
        # Independent check of non-negativity on a fine lat-long grid.
        th, ph = np.meshgrid(np.linspace(0, np.pi, 400), np.linspace(0, 2 * np.pi, 800))
        d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
        assert (real_sh(d, 2) @ convolve(c, K * w)).min() >= -1e-12

    def test_dering_refuses_negative_mean(self):
        c = np.zeros((9, 1))
        c[0] = -1
        with pytest.raises(ValueError):
            dering_window(c, [lambert_kernel(2)])
