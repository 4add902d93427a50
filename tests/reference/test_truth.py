"""The ground truths (:mod:`shbake.reference.truth`) of a map seen turned (a scene probe's
pose): each against the map itself turned by its pixels."""

from types import SimpleNamespace

import numpy as np

from shbake.envmap.turn import turn_latlong, turn_matrix
from shbake.reference.truth import ggx_truth, irradiance_truth
from tests.helpers import smooth_map
from tests.probe_cases import random_pairs

DEG = 90.0
"""A quarter turn: a whole number of columns of any map whose width is a multiple of 4, so
the pixels turn exactly (:func:`~shbake.envmap.turn.turn_latlong`)."""


def _maps():
    pixels = smooth_map(32, sun=40.0)
    return SimpleNamespace(pixels=pixels), SimpleNamespace(pixels=turn_latlong(pixels, DEG))


class TestGgxTruth:
    def test_turned_normals_are_the_turned_map(self):
        """The lat-long GGX integrals take the map as it is; a turn is applied to the normals
        and views instead, and must give what the turned map's pixels give."""
        env, turned = _maps()
        views, normals = random_pairs(16, 3)
        got = ggx_truth(None, env, normals, views, rotation=turn_matrix(DEG), alpha=0.2,
                        samples=16384)  # fmt: skip
        want = ggx_truth(None, turned, normals, views, alpha=0.2, samples=16384)
        np.testing.assert_allclose(got, want, rtol=0.02)
        unturned = ggx_truth(None, env, normals, views, alpha=0.2, samples=16384)
        assert np.abs(unturned - want).max() > 10 * np.abs(got - want).max()


class TestIrradianceTruth:
    def test_turned_directions_are_the_turned_map(self):
        from shbake.envmap.environment import Environment

        pixels = smooth_map(32, sun=40.0)
        env = Environment(pixels, "latlong", {})
        turned = Environment(turn_latlong(pixels, DEG), "latlong", {})
        _, normals = random_pairs(16, 4)
        got = irradiance_truth(None, env, normals, None, rotation=turn_matrix(DEG))
        np.testing.assert_allclose(got, irradiance_truth(None, turned, normals, None),
                                   rtol=1e-9)  # fmt: skip
