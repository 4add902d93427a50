"""SHRM benchmarks (Ramamoorthi & Hanrahan 2002, Tables 4 and 5, §7.5) and the GGX comparison.

Sections (all in one process, same machine state; ``--sections`` picks):

``phong``   Table 4: frequency- vs angular-space prefiltering of the radially
            symmetric Phong lobe, ``s = 8 … 512``. Map: city box-filtered to
            128×256 (``S_L = 128``, as the paper); output: a 64²×6 cube (the
            paper: 128×128). Frequency: ``F = 1 + sqrt(6s)`` (the paper's
            conservative ε = 0.01), BRDF coefficients + projection + SHRM,
            best of 3. Angular: ε = 0.05 truncation (appendix D), best of 2.
            The crossover ``s*`` is where the log-log fit of the ratio crosses 1.
``micro``   Table 5: the simplified microfacet ``σ = 0.1 … 0.5``; orders from ε = 0.03
            (printed beside the paper's), a 32²×6 output, ``T_B² = 100`` views on a
            10×10 grid of ``(θ_o, φ_o)``. Frequency: SHRM + eq. 12 for the 100 views.
            Angular: 4 of the views timed, ×25 (stated).
``speed``   σ = 0.1 with ``F = 24``, ``P = 3`` at 64²×6 on the full 256×512 city map
            (paper: 1.55 s), best of 5; the eq. 12 update at 64²×6 (best of 20) and a
            192² sphere frame (eq. 12 + cube lookup).
``ggx``     The GGX SHRM against ground truth (:func:`shbake.reference.ggx.ggx_integrals`,
            4096 samples) and the split-sum probe (default config) on the six shared
            maps × roughness 0.25, 0.4 (``α = r²``) × F0 1, 0.04 × 4 view yaws, 32²
            spheres: MSE per case, wins, bytes per probe.

Threads: numba uses ``NUMBA_NUM_THREADS`` (2 on these machines); the figures
were taken while other jobs shared the 2 cores, so they are provisional.

    NUMBA_NUM_THREADS=2 .venv/bin/python bench/shrm.py [--sections phong,micro,speed,ggx]

Writes ``bench/results/shrm.md``.
"""

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from shbake.bakers.shrm import (
    F_LIMIT,
    bake_shrm,
    brdf_coefficients,
    make_reflection_brdf,
    select_orders,
)
from shbake.bakers.shrm_angular import angular_reflection_maps
from shbake.envmap import load_environment
from shbake.envmap.environment import Environment
from shbake.preview.sphere import sphere_geometry
from shbake.shading.shrm import evaluate_ggx_shrm, reflection_cube, shade
from shbake.texture.cube import cube_directions

HERE = Path(__file__).resolve().parent
HDRI = HERE.parent.parent / "shared" / "hdri"
if not HDRI.exists():
    HDRI = HERE.parent / "data_samples"
MAPS = ("city", "esplanade", "forest", "night", "studio", "sunset")
TABLE4 = {8: 830.6, 16: 333.6, 32: 137.1, 64: 52.6, 128: 21.9, 256: 7.7, 512: 3.3}
TABLE5 = {0.1: (24, 3, 923, 2.70, 1.55), 0.2: (12, 2, 2744, 1.55, 0.72),
          0.3: (7, 2, 5731, 1.49, 0.67), 0.4: (5, 2, 9034, 1.47, 0.65),
          0.5: (5, 2, 12580, 1.45, 0.64)}  # fmt: skip


CPU = {}
"""CPU seconds (all threads) of the last :func:`best_of`'s best run, under ``CPU["last"]``."""


def best_of(f, n):
    """Shortest wall time of ``n`` runs and that run's result (its CPU time in ``CPU``)."""
    best, out = np.inf, None
    for _ in range(n):
        t0, c0 = time.perf_counter(), time.process_time()
        res = f()
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
        if dt < best:
            best, out, CPU["last"] = dt, res, dc
    return best, out


def env_at(name, height):
    env = load_environment(str(HDRI / f"{name}.exr"), quiet=True)
    px = env.pixels.astype(np.float64)
    while px.shape[0] > height:
        px = 0.25 * (px[0::2, 0::2] + px[1::2, 0::2] + px[0::2, 1::2] + px[1::2, 1::2])
    return Environment(px.astype(np.float32), "latlong", dict(env.meta))


def section_phong(lines):
    env = env_at("city", 128)
    R = cube_directions(64)
    R = R.reshape(-1, 3)
    rows = []
    for s, paper in TABLE4.items():
        rb = make_reflection_brdf("phong-lobe", {"s": float(s)})
        F = min(F_LIMIT, int(np.ceil(1 + np.sqrt(6 * s))))
        bake_shrm(env, rb, F=F, face_size=8)  # compile
        t_f, _ = best_of(lambda: bake_shrm(env, rb, F=F, face_size=64), 3)  # noqa: B023
        angular_reflection_maps(env.pixels, rb, R[:10], [[0, 0, 1.0]], 0.05)
        t_a, _ = best_of(lambda: angular_reflection_maps(env.pixels, rb, R, [[0, 0, 1.0]], 0.05), 2)  # noqa: B023,E501
        rows.append((s, F, t_a, t_f, t_a / t_f, paper))
        print(f"phong s={s}: angular {t_a:.3f}s freq {t_f:.3f}s ratio {t_a / t_f:.1f}", flush=True)
    ls, lr = np.log([r[0] for r in rows]), np.log([r[4] for r in rows])
    slope, icpt = np.polyfit(ls, lr, 1)
    s_star = float(np.exp(-icpt / slope))
    lines += [
        "## Table 4: Phong lobe, frequency vs angular prefiltering",
        "",
        "City box-filtered to 128×256 (S_L = 128); output 64²×6 texels; frequency "
        "F = 1 + sqrt(6s) (ε ≈ 0.01), angular ε = 0.05 (appendix D). Same process, same run.",
        "",
        "| s | F | angular (s) | frequency (s) | ratio ang/freq | paper ratio |",
        "|---|---|---|---|---|---|",
    ]
    lines += [f"| {s} | {F} | {a:.3f} | {f:.3f} | {r:.1f} | {p} |" for s, F, a, f, r, p in rows]
    lines += [
        "",
        f"Log-log fit of the ratio: slope {slope:.2f} (theory −1.5: ratio ∝ s^(−3/2)); "
        f"crossover s* ≈ {s_star:.0f} (ratio 1; the paper's fit of its Table 4 gives ≈ 1000, "
        "its theory S_L^(4/3) = 640 for S_L = 128).",
        "",
    ]


def grid_views(n=10):
    th = np.pi * (np.arange(n) + 0.5) / n
    ph = 2 * np.pi * (np.arange(n) + 0.5) / n
    t, p = np.meshgrid(th, ph, indexing="ij")
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)


def section_micro(lines):
    env = env_at("city", 128)
    R = cube_directions(32)
    R = R.reshape(-1, 3)
    views = grid_views(10)
    rows = []
    for sigma, (pF, pP, pang, _pfreq, pshrm) in TABLE5.items():
        rb = make_reflection_brdf("microfacet", {"sigma": sigma})
        co = brdf_coefficients(rb, F_LIMIT, 8)
        o = select_orders(co, 0.03)
        bake_shrm(env, rb, F=o.F, P=o.P, face_size=8)

        def freq(rb=rb, o=o):
            b = bake_shrm(env, rb, F=o.F, P=o.P, face_size=32)
            t0 = time.perf_counter()
            for v in views:
                reflection_cube(b.cube, v)
            return b.timings["total"], time.perf_counter() - t0

        t_tot, (t_shrm, t_maps) = best_of(freq, 3)
        angular_reflection_maps(env.pixels, rb, R[:10], views[:1], 0.03)
        t_a4, _ = best_of(
            lambda rb=rb: angular_reflection_maps(env.pixels, rb, R, views[::25], 0.03), 1
        )
        t_img = t_a4 / 4
        rows.append((sigma, o.F, o.P, pF, pP, t_img * 100, t_img, t_tot, t_shrm, pang, pshrm))
        print(f"micro σ={sigma}: F,P={o.F},{o.P} ang/img {t_img:.2f}s freq {t_tot:.3f}s",
              flush=True)  # fmt: skip
    lines += [
        "## Table 5: simplified microfacet (eq. 11), ε = 0.03",
        "",
        "City at 128×256; output 32²×6; T_B² = 100 views. Angular: 4 views timed, ×25. "
        "Frequency total = SHRM bake (BRDF coefficients at the chosen F, P + projection + "
        "SHRM) + eq. 12 for the 100 views.",
        "",
        "| σ | F, P (ours) | F, P (paper) | angular 100 maps (s) | angular / map (s) | "
        "frequency total (s) | SHRM (s) | ratio ang-total/freq-total | ratio ang-map/SHRM | "
        "paper: ang-total/freq-total, ang-map/SHRM |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for sg, F, P, pF, pP, a100, a1, tt, ts, pang, pshrm in rows:
        pf = TABLE5[sg][3]
        lines.append(
            f"| {sg} | {F}, {P} | {pF}, {pP} | {a100:.1f} | {a1:.3f} | {tt:.3f} | {ts:.3f} | "
            f"{a100 / tt:.0f} | {a1 / ts:.1f} | {pang / pf:.0f}, {pang / 100 / pshrm:.1f} |"
        )
    lines.append("")


def section_speed(lines):
    env = load_environment(str(HDRI / "city.exr"), quiet=True)
    rb = make_reflection_brdf("microfacet", {"sigma": 0.1})
    bake_shrm(env, rb, F=24, P=3, face_size=8)
    t_fixed, b = best_of(lambda: bake_shrm(env, rb, F=24, P=3, face_size=64), 5)
    cpu_fixed = CPU["last"]
    t_eps, b2 = best_of(lambda: bake_shrm(env, rb, eps=0.03, face_size=64), 3)
    steps = ", ".join(f"{k} {v:.3f}" for k, v in b.timings.items())
    view = np.array([0.0, 0.0, 1.0])
    t_eq12, _ = best_of(lambda: reflection_cube(b.cube, view), 20)
    cpu_eq12 = CPU["last"]
    n, _, mask = sphere_geometry(192)
    n = n[mask]
    t_frame, _ = best_of(lambda: shade(reflection_cube(b.cube, view), n, view), 10)
    lines += [
        "## Bake and update speed (σ = 0.1, F = 24, P = 3, 64²×6)",
        "",
        f"- bake with F, P given, full 256×512 city map: **{t_fixed:.3f} s** (best of 5; "
        f"steps of that run: {steps}); CPU time of that run {cpu_fixed:.3f} s over all "
        f"threads (≈ {cpu_fixed / 2:.3f} s wall on 2 idle cores); paper 1.55 s (1.4 GHz "
        "Pentium IV); target < 0.3 s.",
        f"- bake with the orders chosen from ε = 0.03 (BRDF coefficients to F = 64, P = 16 "
        f"first): {t_eps:.3f} s (chose F = {b2.F}, P = {b2.P}).",
        f"- eq. 12 update of the 64²×6 reflection cube (16 terms × RGB): {t_eq12 * 1e3:.2f} ms "
        f"= **{1 / t_eq12:.0f} updates/s** (CPU {cpu_eq12 * 1e3:.2f} ms; target ≥ 30; "
        "paper ≈ 30 frames/s).",
        f"- whole 192² sphere frame (eq. 12 + seam-correct bilinear lookup): "
        f"{t_frame * 1e3:.1f} ms = {1 / t_frame:.0f} frames/s.",
        "",
    ]


GGX_CONFIG = {0.25: (48, 8, 64), 0.4: (32, 6, 64)}
"""(F, P, face size) per perceptual roughness: ε = 0.01 is out of reach (see the section)."""


def section_ggx(lines, configs=GGX_CONFIG, maps=MAPS):
    from shbake.bakers.splitsum import SplitSumConfig, prefilter_chain
    from shbake.batch.probe_jobs import shared_dfg_table
    from shbake.evaluation.probes import sphere_views
    from shbake.reference.ggx import ggx_integrals
    from shbake.shading.splitsum import evaluate_splitsum

    # the paper's plain split-sum with its levels at exactly the evaluated widths α = r²
    cfg = SplitSumConfig(alphas=tuple(r * r for r in sorted(configs)))
    dfg = shared_dfg_table()
    rows = []
    caps = {}
    for r in (0.25, 0.4):
        F, P, S = configs[r]
        for f0 in (1.0, 0.0):
            co = brdf_coefficients(
                make_reflection_brdf("ggx", {"alpha": r * r, "F0": f0}), F_LIMIT, 16
            )
            o = select_orders(co, 0.01)
            caps[(r, f0)] = (o, co.captured()[F, P], F, P)
    bake_time = []
    shrm_bytes_of = {}
    for name in maps:
        env = load_environment(str(HDRI / f"{name}.exr"), quiet=True)
        chain = prefilter_chain(env.pixels, cfg)
        split_bytes = sum(lv.nbytes for lv in chain) + dfg.astype(np.float32).nbytes
        for r in (0.25, 0.4):
            a = r * r
            F, P, S = configs[r]
            t0 = time.perf_counter()
            b0 = bake_shrm(env, make_reflection_brdf("ggx", {"alpha": a, "F0": 1.0}), F=F, P=P,
                           face_size=S)  # fmt: skip
            b1 = bake_shrm(env, make_reflection_brdf("ggx", {"alpha": a, "F0": 0.0}), F=F, P=P,
                           face_size=S)  # fmt: skip
            bake_time.append(time.perf_counter() - t0)
            levels = [(a, b0.cube, b1.cube)]
            shrm_bytes = b0.cube.nbytes + b1.cube.nbytes
            shrm_bytes_of[r] = shrm_bytes
            for yaw in (0.0, 90.0, 180.0, 270.0):
                n, v, _ = sphere_views(32, yaw)
                V = np.broadcast_to(v, n.shape)
                e0, e1 = ggx_integrals(env.pixels, V, n, a, 4096)
                c0, c1 = ggx_integrals(env.pixels, V, n, a, 1024)
                for mat, f0 in (("chrome", 1.0), ("dielectric", 0.04)):
                    truth = f0 * e0 + (1 - f0) * e1
                    noise = float(np.mean((f0 * c0 + (1 - f0) * c1 - truth) ** 2)) / 5
                    sh = evaluate_ggx_shrm(levels, V, n, a, f0)
                    ss = evaluate_splitsum(chain, cfg.alphas, dfg, V, n, a, (f0,) * 3)
                    rows.append((name, r, mat, yaw, float(np.mean((sh - truth) ** 2)),
                                 float(np.mean((ss - truth) ** 2)), noise, shrm_bytes,
                                 split_bytes))  # fmt: skip
        print(f"ggx {name} done", flush=True)
    wins = sum(1 for row in rows if row[4] < row[5])
    lines += [
        "## GGX SHRM vs split-sum vs ground truth",
        "",
        f"Six maps × roughness 0.25, 0.4 (α = r²) × chrome (F0 1) / dielectric (F0 0.04) × "
        f"yaws 0, 90, 180, 270 × 32² spheres = {len(rows)} cases. SHRM: E0 (F0 = 1) and "
        f"E1 (F0 = 0) SHRMs at (F, P, face) = {configs[0.25]} for r 0.25 and "
        f"{configs[0.4]} for r 0.4, combined F0 E0 + (1 − F0) E1 "
        "(:func:`shbake.shading.shrm.evaluate_ggx_shrm`, per-pixel eq. 7). Truth: "
        "ggx_integrals at α = r², 4096 samples (noise estimate from 1024). Split-sum: the "
        "paper's plain split-sum (Karis, 1024 samples per texel) with levels at these α.",
        "",
        f"**SHRM MSE below split-sum's in {wins}/{len(rows)} cases "
        f"({100 * wins / len(rows):.0f} %)**; goal ≥ 90 %.",
        "",
        "ε = 0.01 by the paper's energy rule is not reachable for GGX within F ≤ 64, P ≤ 16 "
        "(the 4D energy of ρ̂ sits at grazing views): captured fraction at F = 64, P = 16 "
        "(and at the F, P used):",
        "",
    ]
    for (r, f0), (o, cap, F, P) in caps.items():
        lines.append(f"- r {r}, F0 {f0:g}: {1 - o.eps_brdf:.3f} ({cap:.3f} at {F}, {P})")
    lines += [
        "",
        "Bytes per probe: SHRM (two float32 cubes) "
        + ", ".join(f"r {r}: {b:,}" for r, b in sorted(shrm_bytes_of.items()))
        + f"; split-sum {rows[0][8]:,} (all levels + DFG table, float32, every roughness). "
        f"SHRM bake per map and roughness (two SHRMs): median {np.median(bake_time):.1f} s.",
        "",
        "| map | r | material | yaw | MSE SHRM | MSE split-sum | truth noise |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, r, mat, yaw, ms, mp, noise, _, _ in rows:
        lines.append(f"| {name} | {r} | {mat} | {yaw:.0f} | {ms:.3e} | {mp:.3e} | {noise:.1e} |")
    lines.append("")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sections", default="phong,micro,speed,ggx")
    ap.add_argument("--out", default=str(HERE / "results" / "shrm.md"))
    args = ap.parse_args()
    lines = [
        "# SHRM benchmarks (bench/shrm.py)",
        "",
        f"numba threads: {os.environ.get('NUMBA_NUM_THREADS', 'default')}; load average while "
        f"starting: {os.getloadavg()[0]:.1f} on 2 cores (shared with other jobs): wall times are "
        "provisional; the speed section adds CPU time.",
        "",
    ]
    for name in args.sections.split(","):
        {"phong": section_phong, "micro": section_micro, "speed": section_speed,
         "ggx": section_ggx}[name](lines)  # fmt: skip
        Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
