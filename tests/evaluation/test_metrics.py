"""``shbake/evaluation/metrics.py``: errors against a black reference."""

import numpy as np

from shbake.evaluation.metrics import BLACK_LEVEL, relative_error_energy, relative_rms_error


class TestRelativeErrorEnergy:
    def test_black_result_of_a_black_reference_is_no_error(self):
        """A probe of a black map shades its fit's floor (1e-30): it was reported as a
        relative error of 2.5e121."""
        assert relative_error_energy(np.full(8, 1e-30), np.zeros(8)) == 0.0
        assert relative_rms_error(np.zeros(8), np.zeros(8)) == 0.0

    def test_light_where_the_reference_is_black_is_infinite(self):
        assert relative_error_energy(np.full(8, 10 * BLACK_LEVEL), np.zeros(8)) == np.inf

    def test_against_its_definition(self):
        got, ref = np.array([3.0, 1.0, 2.0]), np.array([4.0, 1.0, 0.0])
        assert relative_error_energy(got, ref) == (1.0 + 0.0 + 4.0) / 17.0
