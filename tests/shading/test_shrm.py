"""SHRM shading (:mod:`shbake.shading.shrm`): the mirror direction about the normal."""

import numpy as np
import pytest

from shbake.errors import ParameterError
from shbake.shading.shrm import reflect


class TestReflect:
    def test_mirror_about_the_normal_for_any_normal_length(self):
        rng = np.random.default_rng(3)
        n = rng.normal(size=(1000, 3))
        n_hat = n / np.linalg.norm(n, axis=1, keepdims=True)
        v = np.array([0.3, -0.2, 0.9])
        v_hat = v / np.linalg.norm(v)
        for scale in (1e-150, 1.0, 1e150):
            r = reflect(n * scale, v)
            # unit length, same angle to the normal, in the plane of n and v
            np.testing.assert_allclose(np.linalg.norm(r, axis=1), 1.0, atol=1e-14)
            np.testing.assert_allclose(np.sum(r * n_hat, 1), n_hat @ v_hat, atol=1e-14)
            np.testing.assert_allclose(np.sum(np.cross(n_hat, v_hat) * r, 1), 0.0, atol=1e-14)

    def test_refuses_zero_normals_and_several_views(self):
        with pytest.raises(ParameterError):
            reflect([[0.0, 0.0, 0.0]], [0.0, 0.0, 1.0])
        with pytest.raises(ParameterError):
            reflect([[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]])
