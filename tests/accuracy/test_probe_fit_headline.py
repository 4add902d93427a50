"""``probe-fit``'s headline error (issue 32, Deliver 1): the error of what an engine shades
from the written probe — ``E0`` (F0 = 1) over the probe's α range — against brute force,
within 10 % of an independent measurement.

The oracle reads ``/p``, ``/q``, ``/knots`` and ``alpha_range`` from the file with h5py,
evaluates the SH-exp model as docs (Silvennoinen et al. 2025, eq. 9–12; shbake's v2 hat
blend of the knots) define it, and integrates the GGX lobe (``D G1(v) G1(l) / (4 n·v)``,
separable Smith, SPEC §4) over every texel of the map, 2×2 points per texel with exact
lat-long solid angles, at the normals of a 41² grid over the visible disc: no MIS, no point set and
no shader of shbake's. (The SH basis is :func:`shbake.sh.basis.real_sh`, as in
``tests/accuracy/test_brdf_table_headline.py``.)
"""

import json

import h5py
import numpy as np

from shbake.sh.basis import real_sh
from tests.helpers import write_test_exr

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def soft_map(h: int = 32) -> np.ndarray:
    """A smooth sky (no compact light, so the texel sum converges): a gradient and a broad
    warm glow."""
    theta = (np.arange(h) + 0.5) / h * np.pi
    phi = (np.arange(2 * h) + 0.5) / (2 * h) * 2 * np.pi
    glow = np.exp(-((theta[:, None] - 1.0) ** 2 + (phi[None, :] - 2.0) ** 2) / 0.3)
    sky = 0.2 + 0.8 * np.cos(theta / 2)[:, None] ** 2
    return np.stack([sky + 3 * glow, sky + 2 * glow, 1.5 * sky + glow], -1)


def texel_points(h: int, w: int, sub: int = 2):
    """Directions and solid angles of ``sub × sub`` points per texel (SPEC §3 lat-long)."""
    t_edges = np.linspace(0, np.pi, h * sub + 1)
    omega_row = 2 * np.pi / (w * sub) * (np.cos(t_edges[:-1]) - np.cos(t_edges[1:]))
    theta = 0.5 * (t_edges[:-1] + t_edges[1:])
    phi = (np.arange(w * sub) + 0.5) / (w * sub) * 2 * np.pi
    st = np.sin(theta)[:, None]
    d = np.stack(np.broadcast_arrays(st * np.sin(phi), np.cos(theta)[:, None],
                                     -st * np.cos(phi)), -1)  # fmt: skip
    return d.reshape(-1, 3), np.repeat(omega_row, w * sub)


def ggx_e0(img, normals, alpha):
    """``∫ L D G1(v) G1(l) / (4 n·v) dl`` at view +Z, luminance, per normal."""
    h, w, _ = img.shape
    dirs, omega = texel_points(h, w)
    lum = np.repeat(np.repeat(img @ LUMINANCE, 2, 0), 2, 1).reshape(-1) * omega
    v = np.array([0.0, 0.0, 1.0])

    def g1(c):
        return 2 * c / (c + np.sqrt(alpha**2 + (1 - alpha**2) * c**2))

    out = []
    for n in normals:
        nl = dirs @ n
        nv = n @ v
        hv = dirs + v
        hv /= np.linalg.norm(hv, axis=1, keepdims=True)
        nh = hv @ n
        d = alpha**2 / (np.pi * (nh**2 * (alpha**2 - 1) + 1) ** 2)
        f = np.where(nl > 0, d * g1(np.maximum(nl, 1e-12)) * g1(nv) / (4 * nv), 0.0)
        out.append(np.sum(f * lum))
    return np.array(out)


def shexp_e0(path, normals, alpha):
    """The probe's ``E0 = P(ρ) Q(h_ρ)`` (eq. 9–12), luminance, view +Z."""
    with h5py.File(path, "r") as f:
        p, q, knots = f["p"][()], f["q"][()], f["knots"][()]
    a = min(max(alpha, knots[0]), knots[-1])
    hat = np.array([np.interp(a, knots, e) for e in np.eye(len(knots))])  # hat functions
    pa, qa = np.tensordot(hat, p, 1), np.tensordot(hat, q, 1)
    v = np.array([0.0, 0.0, 1.0])
    rho = 2 * (normals @ v)[:, None] * normals - v
    h_rho = normals + rho
    h_rho /= np.linalg.norm(h_rho, axis=1, keepdims=True)

    def vmf(n_coeffs):
        lmax = int(round(np.sqrt(n_coeffs))) - 1
        l = np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
        return lmax, np.exp(-l * (l + 1) * a / 2)

    lp, wp = vmf(pa.shape[0])
    lq, wq = vmf(qa.shape[0] + 1)
    big_p = np.exp((real_sh(rho, lp) * wp) @ pa)
    big_q = np.exp((real_sh(h_rho, lq)[:, 1:] * wq[1:]) @ qa)
    return (big_p * big_q) @ LUMINANCE


def test_probe_fit_headline(tmp_path, run_cli):
    img = soft_map()
    src = write_test_exr(tmp_path / "soft.exr", img)
    code, out, err = run_cli("probe-fit", src, "--out-dir", tmp_path / "p", "--json")
    assert code == 0, err
    (probe,) = json.loads(out)["probes"]
    head = probe["error"]
    assert err.splitlines()[0].startswith(f"{src}: error {head['value']:.2%} (relative RMS")
    with h5py.File(tmp_path / "p" / "soft.h5", "r") as f:
        lo, hi = json.loads(f.attrs["alpha_range"])  # a JSON attribute (docs/FORMAT.md)
    c = (np.arange(41) + 0.5) / 41 * 2 - 1  # a 41² grid over the visible disc (not 32²)
    gx, gy = np.meshgrid(c, c)
    inside = gx**2 + gy**2 < 1
    x, y = gx[inside], gy[inside]
    normals = np.column_stack([x, y, np.sqrt(1 - x**2 - y**2)])
    normals = normals[normals[:, 2] > 1e-3]
    got = np.concatenate([shexp_e0(tmp_path / "p" / "soft.h5", normals, a)
                          for a in (lo, (lo + hi) / 2, hi)])  # fmt: skip
    ref = np.concatenate([ggx_e0(img, normals, a) for a in (lo, (lo + hi) / 2, hi)])
    mine = float(np.sqrt(np.sum((got - ref) ** 2) / np.sum(ref**2)))
    assert abs(head["value"] - mine) <= 0.1 * mine, (head["value"], mine)
