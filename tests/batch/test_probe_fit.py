"""``probe-fit``'s unit of work (:mod:`shbake.batch.probe_fit`): a poor fit is named with a fix."""


class TestFitWarnings:
    def test_poor_fit_named_with_a_fix(self):
        from shbake.batch.probe_fit import FIT_ERROR_WARNING, fit_warnings

        rows = [{"source": "a.exr", "error": {"value": FIT_ERROR_WARNING / 2}},
                {"source": "b.exr", "error": {"value": FIT_ERROR_WARNING * 1.4}}]  # fmt: skip
        (w,) = fit_warnings(rows)
        assert "1 of 2 probes" in w and "b.exr" in w and "--sets" in w
        assert fit_warnings(rows[:1]) == []
