"""The GGX SHRM column of ``probe-eval`` (issue 13, item 7; :mod:`shbake.batch.probe_eval`).

The SHRM probe is checked against the independent ground truth of the
evaluation (:func:`shbake.reference.ggx.ggx_integrals`, MIS Monte Carlo of the
GGX BRDF against the map's pixels): its error falls as ``F``, ``P`` grow. The
order selection's shortfall at ε = 0.01 is measured (the captured energy is
monotone in ``F`` and ``P``, so the value at the caps bounds every choice), and
the report carries the three families (SH-exp, split-sum, SHRM) with ``n/a``
where a probe does not cover a width. The command: ``tests/cli/test_probe_eval.py``; the
reported figures: ``tests/accuracy/test_probe_eval_shrm.py``. Every probe's bake is timed
per map (lower bounds only: a baker slowed by a known sleep must show at least that sleep).
"""

import time
from pathlib import Path

import numpy as np
import pytest

from shbake.batch.probe_eval import (
    EVALUATED,
    ShrmProbe,
    evaluate_maps,
    evaluation_alphas,
    ggx_shrm_coefficients,
    markdown_report,
    present_comparisons,
    shrm_cube_bytes,
    shrm_orders,
    shrm_shortfalls,
    split_levels,
    win_table,
)
from shbake.brdf.reflection import F_LIMIT, P_LIMIT, brdf_coefficients, make_reflection_brdf
from shbake.brdf.reflection import default_quadrature as shrm_quadrature
from shbake.envmap import load_environment
from shbake.envmap.environment import Environment
from shbake.errors import ParameterError
from shbake.evaluation.probes import ALPHAS, sphere_views
from shbake.reference.ggx import ggx_integrals
from tests.helpers import map_path


@pytest.fixture(scope="module")
def forest64():
    """The forest sample box-filtered to 64×128 (every side sees the same pixels)."""
    env = load_environment(str(map_path("forest")), quiet=True)
    px = env.pixels.astype(np.float64)
    while px.shape[0] > 64:
        px = 0.25 * (px[0::2, 0::2] + px[1::2, 0::2] + px[0::2, 1::2] + px[1::2, 1::2])
    return Environment(px.astype(np.float32), "latlong", dict(env.meta))


def orders_row(alpha, F, P):
    term = {"F": F, "P": P, "captured": None, "reached": False}
    return {"alpha": alpha, "roughness": float(np.sqrt(alpha)), "E0": term, "E1": dict(term)}


class TestShrmProbe:
    def test_converges_to_ground_truth_as_F_P_grow(self, forest64):
        """r = 0.5 (α 0.25), a 12² sphere seen from yaw 90°: the relative RMS error against
        the MIS truth (8192 samples, its own noise ≈ 0.13 %) falls at every step of
        (F, P) = (2, 0) … (32, 8) for chrome and dielectric (measured 0.26 → 0.013 and
        0.44 → 0.040)."""
        a = 0.25
        n, v, _ = sphere_views(12, 90.0)
        V = np.ascontiguousarray(np.broadcast_to(v, n.shape))
        e0, e1 = ggx_integrals(forest64.pixels, V, n, a, 8192)
        errs = []
        for F, P in ((2, 0), (4, 1), (8, 2), (16, 4), (32, 8)):
            probe = ShrmProbe(forest64, [orders_row(a, F, P)], 16, 0.01)
            row = []
            for f0 in (1.0, 0.04):
                truth = f0 * e0 + (1.0 - f0) * e1
                s = probe.shade(n, V, alpha=a, f0=f0)
                row.append(np.sqrt(np.mean((s - truth) ** 2) / np.mean(truth**2)))
            errs.append(row)
        errs = np.array(errs)
        assert np.all(np.diff(errs, axis=0) < 0), errs
        assert errs[-1, 0] < 0.02 and errs[-1, 1] < 0.06, errs
        assert errs[0, 0] > 5 * errs[-1, 0] and errs[0, 1] > 5 * errs[-1, 1]

    def test_covers_only_its_widths_and_counts_its_bytes(self, forest64):
        probe = ShrmProbe(forest64, [orders_row(0.25, 4, 1)], 8, 0.01)
        assert probe.covers(alpha=0.25) and not probe.covers(alpha=0.36)
        c0, c1 = probe.cubes(0.25)
        assert c0.shape == (6, 8, 8, 4, 3) and c0.dtype == np.float32
        assert probe.nbytes == c0.nbytes + c1.nbytes == 2 * shrm_cube_bytes(8, 1)
        with pytest.raises(ParameterError, match="not one of"):
            probe.cubes(0.5)

    def test_seconds_sum_its_bakes(self, forest64, monkeypatch):
        """``seconds`` sums every ``bake_shrm`` call: none before the first use, none when an
        ``α``'s cubes are held, again when a dropped ``α`` comes back (each call slowed by
        0.2 s: at least 0.2 s per call counted)."""
        import shbake.bakers.shrm as shrm_module

        calls, original = [], shrm_module.bake_shrm

        def slow(*args, **kwargs):
            calls.append(args[1])
            time.sleep(0.2)
            return original(*args, **kwargs)

        monkeypatch.setattr(shrm_module, "bake_shrm", slow)
        probe = ShrmProbe(forest64, [orders_row(0.25, 2, 0), orders_row(0.36, 2, 0)], 4, 0.01)
        assert probe.seconds == 0.0 and probe.bakes == 0
        probe.cubes(0.25)
        probe.cubes(0.25)
        assert probe.bakes == len(calls) == 2 and probe.seconds >= 0.2 * 2
        probe.cubes(0.36)
        probe.cubes(0.25)
        assert probe.bakes == len(calls) == 6 and probe.seconds >= 0.2 * 6


class TestShrmOrders:
    def test_reached_flag_and_capped_orders(self):
        """r = 0.5: E0 reaches 1 − ε = 0.99 inside the caps; E1 (the Fresnel tail, energy at
        grazing views) does not and is reported at the caps with what it captures."""
        (row,) = shrm_orders([0.25], 0.01)
        e0, e1 = row["E0"], row["E1"]
        assert e0["reached"] and e0["captured"] >= 0.99
        assert e0["F"] < F_LIMIT and e0["P"] < P_LIMIT
        assert not e1["reached"] and (e1["F"], e1["P"]) == (F_LIMIT, P_LIMIT)
        assert 0.85 < e1["captured"] < 0.99
        (line,) = shrm_shortfalls({"shrm": {"eps": 0.01, "F_limit": F_LIMIT,
                                            "P_limit": P_LIMIT, "orders": [row]}})  # fmt: skip
        assert "not reachable" in line and "E1" in line and f"captures {e1['captured']:.3f}" in line

    @pytest.mark.parametrize("r", [0.25, 0.4])
    def test_eps_001_unreachable_within_the_caps(self, r):
        """The captured fraction is monotone in F and P (partial sums of squares), so its
        value at (64, 16) bounds every choice inside the caps: below 0.99 for both E0 and
        E1 at r 0.25 and 0.4 (measured 0.940 / 0.593 and 0.988 / 0.859)."""
        for f0 in (1.0, 0.0):
            cap = ggx_shrm_coefficients(r * r, f0)[1].captured()
            assert np.all(np.diff(cap, axis=0) >= -1e-12) and np.all(np.diff(cap, axis=1) >= -1e-12)
            assert cap[F_LIMIT, P_LIMIT] < 0.99

    @pytest.mark.slow
    def test_energy_is_quadrature_converged(self):
        """The shortfall is not a quadrature artefact: 640 × 128 × 128 nodes give the same
        captured fraction at the caps (to 0.005) and the same total (to 1 %)."""
        for f0 in (1.0, 0.0):
            rb = make_reflection_brdf("ggx", {"alpha": 0.0625, "F0": f0})
            coarse = ggx_shrm_coefficients(0.0625, f0)[1]
            quad = shrm_quadrature("surface", 640, 128, 128)
            fine = brdf_coefficients(rb, F_LIMIT, P_LIMIT, quad)
            assert fine.total[0] == pytest.approx(coarse.total[0], rel=0.01)
            assert abs(fine.captured()[-1, -1] - coarse.captured()[-1, -1]) < 0.005


class TestCases:
    def test_roughness_to_alpha(self):
        assert evaluation_alphas(None) == ALPHAS
        assert evaluation_alphas([0.4, 0.25, 0.4]) == (0.0625, 0.16)
        with pytest.raises(ParameterError, match="outside"):
            evaluation_alphas([0.05])

    def test_split_levels_at_the_evaluated_widths(self):
        assert split_levels(ALPHAS) == ALPHAS
        assert split_levels([0.16, 0.0625]) == (0.0625, 0.16)
        assert split_levels([0.25]) == (0.25, 1.0) and split_levels([1.0]) == (0.25, 1.0)


class TestEvaluateMaps:
    def test_seconds_for_every_map_and_probe(self, probe_maps):
        """Two small maps at r 0.5 (every probe covers it), a 4² SHRM at ε 0.5: ``seconds``
        has every map and, per map, every evaluated probe (the keys of ``bytes``), each
        finite and positive; the report gives their mean next to the bytes."""
        result = evaluate_maps(probe_maps[:2], 8, 16, roughness=[0.5], shrm_eps=0.5,
                               shrm_face_size=4)  # fmt: skip
        stems = [Path(p).stem for p in probe_maps[:2]]
        assert list(result["seconds"]) == stems
        for stem in stems:
            secs = result["seconds"][stem]
            assert set(secs) == set(result["bytes"]) == set(EVALUATED)
            assert all(np.isfinite(v) and v > 0 for v in secs.values()), secs
        text = markdown_report(result)
        assert "| probe | bytes per probe | bake s (mean of 2 maps) |" in text
        for k, nbytes in result["bytes"].items():
            mean = sum(result["seconds"][m][k] for m in stems) / 2
            assert f"| {k} | {nbytes} | {mean:.3g} |" in text

    def test_each_bake_is_timed(self, probe_maps, monkeypatch):
        """Without the SHRM: each SH-exp asset and each split-sum chain slowed by 0.2 s shows
        at least 0.2 s on every map, and no ``shrm`` entry is reported."""
        import shbake.batch.probe_eval as probe_eval

        def slowed(fn):
            def slow(*args, **kwargs):
                time.sleep(0.2)
                return fn(*args, **kwargs)

            return slow

        for name in ("build_shexp_asset", "prefilter_chain"):
            monkeypatch.setattr(probe_eval, name, slowed(getattr(probe_eval, name)))
        result = evaluate_maps(probe_maps[:2], 8, 16, roughness=[0.5], shrm_eps=None)
        for secs in result["seconds"].values():
            assert set(secs) == set(EVALUATED) - {"shrm"}
            assert all(v >= 0.2 for v in secs.values()), secs


def fake_result():
    mse = [  # (α, shexp_v2, splitsum_plain, shrm)
        (0.0625, None, 2e-3, 1e-3),
        (0.25, 3e-3, 2e-3, 1e-3),
    ]
    rows = [{"material": "chrome", "alpha": a, "yaw": 0.0, "mse_truth_estimate": 1e-9,
             "mse": {"shexp_v2": s, "shexp_paper": s, "splitsum_plain": p,
                     "splitsum_filtered": p, "shrm": m}} for a, s, p, m in mse]  # fmt: skip
    orders = [dict(orders_row(0.0625, 64, 16), E0={"F": 64, "P": 16, "captured": 0.94,
                                                  "reached": False})]  # fmt: skip
    orders[0]["E1"] = {"F": 64, "P": 16, "captured": 0.59, "reached": False}
    return {"maps": {"m": rows}, "bytes": {"shexp_v2": 792, "splitsum_plain": 245760,
                                          "shrm": 2 * shrm_cube_bytes(64, 16)},
            "shrm": {"eps": 0.01, "face_size": 64, "F_limit": 64, "P_limit": 16,
                     "orders": orders}}  # fmt: skip


class TestReport:
    def test_cases_outside_a_range_are_not_counted(self):
        r = fake_result()
        assert win_table(r, "shrm", "splitsum_plain")["total"] == (2, 2)
        assert win_table(r, "shexp_v2", "splitsum_plain")["total"] == (0, 1)
        assert win_table(r, "shrm", "shexp_v2")["total"] == (1, 1)
        assert ("shrm", "shexp_v2") in present_comparisons(r)

    def test_three_columns_bytes_and_orders(self):
        text = markdown_report(fake_result())
        head = next(ln for ln in text.splitlines() if ln.startswith("| map | material | α | yaw"))
        for col in ("SH-exp v2", "split-sum plain", "GGX SHRM"):
            assert col in head
        assert "| m | chrome | 0.0625 | 0 | n/a | n/a | 2.000e-03 | 2.000e-03 | 1.000e-03 |" in text
        assert f"| shrm | {2 * shrm_cube_bytes(64, 16)} |" in text
        assert "| 0.0625 | 0.25 | 64, 16 | 0.9400 | 64, 16 | 0.5900 | no (capped) |" in text
        assert "shrm vs splitsum_plain" in text and "**2/2 (100.0 %)**" in text

    def test_bake_seconds_next_to_bytes(self):
        """The mean bake seconds over the maps that have the probe; ``n/a`` where none has;
        a result written before seconds were measured keeps the bytes-only table."""
        r = fake_result()
        r["seconds"] = {"m": {"shexp_v2": 0.5, "shrm": 2.0}, "n": {"shexp_v2": 0.25, "shrm": 4.0}}
        text = markdown_report(r)
        assert "| probe | bytes per probe | bake s (mean of 2 maps) |" in text
        assert "| shexp_v2 | 792 | 0.375 |" in text and "| splitsum_plain | 245760 | n/a |" in text
        assert f"| shrm | {2 * shrm_cube_bytes(64, 16)} | 3 |" in text
        old = markdown_report(fake_result())
        assert "| probe | bytes per probe |" in old and "bake s" not in old
        assert "| shexp_v2 | 792 |" in old
