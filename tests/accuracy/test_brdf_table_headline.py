"""``brdf-table``'s headline error (issue 32, Deliver 1): the error of what a consumer
evaluates — ``f*`` rebuilt from the bilinear look-up of the written table — against ``f*``
itself, within 10 % of an independent brute-force measurement.

The oracle reads ``/table`` from the file with h5py, looks it up bilinearly as
docs/CONVENTIONS.md defines the parabolic map (written out here), rebuilds
``Σ_i c_i(v) y_i(s)`` on a dense Gauss–Legendre × trapezoid grid of each hemisphere and
compares it with ``f*(s, v) = f(s, v) max(0, s_z)`` evaluated there: no projection and
no Parseval identity, unlike :func:`shbake.batch.brdf_table.table_error`.
"""

import json

import h5py
import numpy as np
import pytest

from shbake.bakers.brdf_table_report import probe_views
from shbake.batch.brdf_table import TABLE_ERROR_VIEWS
from shbake.brdf import make_brdf
from shbake.sh.basis import real_sh

CASES = {
    # Ashikhmin–Shirley (24, 8) at lmax 4: the truncation dominates (issue 32: 52.8 %)
    "anisotropic, truncated": ("ashikhmin-shirley", {"nu": "24", "nv": "8"}, 4, 16),
    # a broad lobe at lmax 6 on 6 × 6 texels: the bilinear look-up dominates
    "broad, coarse table": ("phong", {"n": "2", "rho_d": "0.5", "rho_s": "0.5"}, 6, 6),
}


def sphere_grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Directions and weights: Gauss–Legendre in ``cos θ`` on each hemisphere apart (``f*``
    jumps at the horizon) × ``2n`` trapezoid nodes in ``φ``."""
    x, w = np.polynomial.legendre.leggauss(n)
    ct = np.concatenate([0.5 * (x + 1), -0.5 * (x + 1)])
    wt = np.concatenate([0.5 * w, 0.5 * w])
    phi = 2 * np.pi * (np.arange(2 * n) + 0.5) / (2 * n)
    st = np.sqrt(1 - ct**2)[:, None]
    s = np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), ct[:, None]), -1)
    return s.reshape(-1, 3), (wt[:, None] * np.full(2 * n, np.pi / n)).reshape(-1)


def bilinear(table: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``c(v)`` of ``table (H, W, n, C)``: parabolic map ``p = (x, y)/(1 + z)``, column
    ``(p_x + 1)/2``, row ``(p_y + 1)/2`` at texel centres, edges clamped."""
    h, w = table.shape[:2]
    px, py = v[0] / (1 + v[2]), v[1] / (1 + v[2])
    x, y = (px + 1) / 2 * w - 0.5, (py + 1) / 2 * h - 0.5
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    fx, fy = x - x0, y - y0
    cx = [min(max(i, 0), w - 1) for i in (x0, x0 + 1)]
    cy = [min(max(i, 0), h - 1) for i in (y0, y0 + 1)]
    top = (1 - fx) * table[cy[0], cx[0]] + fx * table[cy[0], cx[1]]
    bottom = (1 - fx) * table[cy[1], cx[0]] + fx * table[cy[1], cx[1]]
    return (1 - fy) * top + fy * bottom


@pytest.mark.parametrize("case", list(CASES))
def test_headline_error_is_the_looked_up_tables(run_cli, tmp_path, case):
    model, params, lmax, size = CASES[case]
    out = tmp_path / "t.h5"
    p_args = [a for k, v in params.items() for a in ("-p", f"{k}={v}")]
    code, stdout, err = run_cli("brdf-table", model, *p_args, "-o", out, "--lmax", lmax,
                                "--size", size, "--samples", "256", "--json")  # fmt: skip
    assert code == 0, err
    summary = json.loads(stdout)
    with h5py.File(out, "r") as f:
        table = np.asarray(f["/table"], dtype=np.float64)
        axes = json.loads(f["/table"].attrs["axes"])
    table = np.moveaxis(table, 0, -1) if axes[0] == "channel" else table[..., None]

    brdf = make_brdf(model, **params)
    s, weight = sphere_grid(384)
    y = real_sh(s, lmax)
    errors = []
    for v in probe_views(*TABLE_ERROR_VIEWS):
        truth = brdf.evaluate(s, v) * np.maximum(s[:, 2:3], 0.0)
        rebuilt = y @ bilinear(table, v)
        errors.append(np.sqrt(weight @ ((rebuilt - truth) ** 2).sum(1)
                              / (weight @ (truth**2).sum(1))))  # fmt: skip
    brute = float(np.mean(errors))
    print(f"\n{case}: headline {summary['error']:.4g}, brute force {brute:.4g}, parts "
          f"{summary['error_parts']}")  # fmt: skip
    assert summary["error"] == pytest.approx(brute, rel=0.10)
    parts = summary["error_parts"]
    assert parts["truncation"] <= summary["error"] and parts["coefficients"] <= summary["error"]
