"""Issue 31: the scene layer against the bare commands at N probes (512×256 maps).

    .venv/bin/python bench/scene_scale.py [--n 100 --n 1000 …] [--work DIR] [--plot FILE]
                                          [--skip make,dask,bare] [--links]
                                          [--maps-per-rule N]

Maps: the six shared maps (``../shared/hdri``, 512×256) rolled by distinct column shifts
(a different file per probe, never two with the same bytes), written as half EXR; with
``--links``, symbolic links to the six maps themselves (probe ``i`` on map ``i mod 6``: the
10,000-probe scene of the issue, whose bake is six maps' work and copies). The
scene: a diffuse material (``env_sh``) and a glossy GGX one with roughness [0.5, 0.9] and
``glossy_probe = 0.3`` (one SH-exp probe per map), the issue's acceptance scene.

Per N, side by side in one run, each command a fresh process from a cold output folder:

* ``plan --jobs 2`` then ``bake --jobs 2``; a second ``bake`` (nothing to do); one map's bytes
  changed, then ``bake`` (its assets only);
* ``plan --emit-make`` (``--maps-per-rule``, 8 unless given) then ``make -j2``; a second
  ``make``;
* ``bake --scheduler`` on a 2-worker ``LocalCluster`` configured as docs/SCENES.md
  recommends (started before the timing, with ``--preload shbake.batch.warm_worker``; the
  nanny's ``MALLOC_TRIM_THRESHOLD_`` unset; Dask's statistical profiler off);
* the bare commands doing the same bakes, all maps in one call each with ``--jobs 2``:
  ``project-env`` at the settings the plan chose, ``probe-fit`` at the plan's fit,
  ``split-sum`` at the plan's chain (a shbake before issue 31: ``project-env`` one process
  per map, no ``split-sum`` row — it took one map a call).

Wall seconds, CPU seconds of the command's process tree (``getrusage(RUSAGE_CHILDREN)``
around it), peak resident memory of the command's own process (the client) and of its
largest descendant (a worker), sampled every 50 ms with psutil. The ratios of the
acceptance (docs/BENCHMARKS.md) are printed as measured.
"""

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import psutil

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared" / "hdri"
SHBAKE = str(Path(sys.executable).with_name("shbake"))
SCENE = """[scene]
name = "scale"
out_dir = "out"

[tolerances]
glossy_probe = 0.3

[[environments]]
map = "maps/*.exr"

[[materials]]
name = "plaster"
kind = "diffuse"

[[materials]]
name = "varnish"
kind = "glossy"
roughness = [0.5, 0.9]
"""


def link_maps(folder: Path, n: int) -> list[Path]:
    """``n`` symbolic links to the six shared maps, in turn."""
    folder.mkdir(parents=True, exist_ok=True)
    sources = sorted(SHARED.glob("*.exr"))
    out = []
    for i in range(n):
        path = folder / f"p{i:05d}.exr"
        out.append(path)
        if not path.is_symlink():
            path.symlink_to(sources[i % len(sources)])
    return out


def make_maps(folder: Path, n: int) -> list[Path]:
    """``n`` distinct 512×256 half EXR maps: the shared maps rolled by distinct columns."""
    import OpenImageIO as oiio

    from shbake.envmap import load_environment

    folder.mkdir(parents=True, exist_ok=True)
    sources = sorted(SHARED.glob("*.exr"))
    pixels = [load_environment(str(p), quiet=True, negative="keep").pixels for p in sources]
    out = []
    for i in range(n):
        src = pixels[i % len(sources)]
        shift = 7 * (i // len(sources)) % src.shape[1] + i // (len(sources) * src.shape[1])
        path = folder / f"p{i:05d}.exr"
        out.append(path)
        if path.exists():
            continue
        img = oiio.ImageOutput.create(str(path))
        img.open(str(path), oiio.ImageSpec(src.shape[1], src.shape[0], 3, "half"))
        img.write_image(np.roll(src, shift, axis=1))
        img.close()
    return out


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _cluster_cpu() -> dict:
    """CPU seconds so far of this process (a LocalCluster's scheduler, started here) and of
    its live descendants (the cluster's nannies and workers; no command is running)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    workers = 0.0
    for c in psutil.Process().children(recursive=True):
        try:
            t = c.cpu_times()
            workers += t.user + t.system
        except psutil.Error:
            pass
    return {"scheduler": r.ru_utime + r.ru_stime, "workers": workers}


def run(args, cwd, env=None, cluster: bool = False) -> dict:
    """Run ``args``; wall s, CPU s of the tree, peak RSS (MiB) of the process and of its
    largest descendant (``cluster``: of this process's other descendants, the Dask
    workers of a LocalCluster started here)."""
    c0, t0 = _children_cpu(), time.perf_counter()
    cluster_cpu0 = _cluster_cpu() if cluster else None
    proc = subprocess.Popen(args, cwd=cwd, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    peak = {"client": 0, "worker": 0}
    stop = threading.Event()

    def sample():
        try:
            p = psutil.Process(proc.pid)
        except psutil.Error:
            return
        while not stop.is_set():
            try:
                peak["client"] = max(peak["client"], p.memory_info().rss)
                others = psutil.Process().children(recursive=True) if cluster else []
                mine = {c.pid for c in p.children(recursive=True)} | {p.pid}
                workers = [c for c in others if c.pid not in mine] if cluster else [
                    c for c in p.children(recursive=True)]  # fmt: skip
                for c in workers:
                    try:
                        peak["worker"] = max(peak["worker"], c.memory_info().rss)
                    except psutil.Error:
                        pass
            except psutil.Error:
                return
            stop.wait(0.05)

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    out, err = proc.communicate()
    stop.set()
    thread.join()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, args))} failed ({proc.returncode}):\n{err[-3000:]}")
    m = {"wall": time.perf_counter() - t0, "cpu": _children_cpu() - c0,
         "client_mib": peak["client"] / 2**20, "worker_mib": peak["worker"] / 2**20,
         "stdout": out}  # fmt: skip
    if cluster:  # the scheduler runs in this process, the workers are its other children
        m["cluster_cpu"] = {k: v - cluster_cpu0[k] for k, v in _cluster_cpu().items()}
    print(f"  {cwd.name}: {' '.join(map(str, args[1:4]))}…: {m['wall']:.1f} s wall, "
          f"{m['cpu']:.1f} s CPU", file=sys.stderr, flush=True)  # fmt: skip
    return m


def bare_commands(work: Path, maps: list[Path], lock: dict) -> dict:
    """``project-env`` and ``probe-fit``, all maps in one call each, ``--jobs 2``, at the
    plan's settings (from the lock of the cold bake). Each bare command's output folder is
    fresh."""
    env_sh = [r for a, r in lock["assets"].items() if a.startswith("env_sh/")]
    shexp = [r for a, r in lock["assets"].items() if a.startswith("shexp/")]
    totals = {"wall": 0.0, "cpu": 0.0, "client_mib": 0.0, "worker_mib": 0.0}
    parts = {}
    for name in ("bare-env", "bare-fit"):
        shutil.rmtree(work / name, ignore_errors=True)
    help_text = subprocess.run([SHBAKE, "project-env", "--help"], capture_output=True,
                               text=True).stdout  # fmt: skip
    many = "--out-dir" in help_text
    if env_sh:
        groups: dict = {}
        for a, r in lock["assets"].items():
            if a.startswith("env_sh/"):
                st = r["settings"]
                key = (st["lmax"], st["extract_sun"], st.get("lights"))
                groups.setdefault(key, []).append(str(work / next(iter(r["inputs"]))))
        for (lmax, sun, lights), paths in sorted(groups.items(), key=str):
            lst = work / "bare-env.list"
            lst.write_text("\n".join(paths) + "\n")
            opts = ["--lmax", str(lmax), "--irradiance-lmax", str(lmax),
                    "--no-tangent-irradiance", "-q"]  # fmt: skip
            opts += ["--extract-sun"] if sun else []
            opts += ["--lights", str(lights)] if lights is not None else []
            if many:
                args = [SHBAKE, "project-env", "--list", str(lst), "--out-dir", "bare-env",
                        "--jobs", "2", *opts]  # fmt: skip
                parts.setdefault("project-env", []).append(run(args, work))
            else:  # a shbake without multi-map project-env: one process per map
                (work / "bare-env").mkdir(exist_ok=True)
                for i, path in enumerate(paths):
                    args = [SHBAKE, "project-env", path, "-o", f"bare-env/{i}.h5", *opts]
                    parts.setdefault("project-env", []).append(run(args, work))
    splitsum = [r for a, r in lock["assets"].items() if a.startswith("splitsum/")]
    if splitsum:
        c = splitsum[0]["settings"]["splitsum"]
        lst = work / "bare-split.list"
        lst.write_text("\n".join(str(work / next(iter(r["inputs"]))) for r in splitsum) + "\n")
        shutil.rmtree(work / "bare-split", ignore_errors=True)
        args = [SHBAKE, "split-sum", "--list", str(lst), "--out-dir", "bare-split", "--jobs",
                "2", "--size", str(c["top"]), "--min-size", str(c["min_size"]), "--alphas",
                ",".join(repr(a) for a in c["alphas"]), "--samples", str(c["samples"]),
                "--prefilter", c["prefilter"], "-q"]  # fmt: skip
        if many:
            parts.setdefault("split-sum", []).append(run(args, work))
    if shexp:
        f = shexp[0]["settings"]["fit"]
        lst = work / "bare-fit.list"
        lst.write_text("\n".join(str(work / next(iter(r["inputs"]))) for r in shexp) + "\n")
        args = [SHBAKE, "probe-fit", "--list", str(lst), "--out-dir", "bare-fit", "--jobs", "2",
                "--sets", str(f["sets"]), "--weights", f["weights"], "--alpha-count",
                str(f["alpha_count"]), "--polish", str(f["polish"]), "--views", str(f["views"]),
                "--normals", str(f["normals"]), "--lmax-p", str(f["lmax_p"]), "--lmax-q",
                str(f["lmax_q"]), "--alpha-range", f"{f['alpha_min']}:{f['alpha_max']}",
                "--samples", str(f["samples"]), "-q"]  # fmt: skip
        parts.setdefault("probe-fit", []).append(run(args, work))
    for ms in parts.values():
        for m in ms:
            for k in ("wall", "cpu"):
                totals[k] += m[k]
            for k in ("client_mib", "worker_mib"):
                totals[k] = max(totals[k], m[k])
    return totals | {"parts": {k: [{x: v for x, v in m.items() if x != "stdout"} for m in ms]
                               for k, ms in parts.items()}}  # fmt: skip


def many_maps_per_rule() -> bool:
    """Whether this shbake's fragments take ``--maps-per-rule`` (issue 31)."""
    done = subprocess.run([SHBAKE, "plan", "--help"], capture_output=True, text=True)
    return "--maps-per-rule" in done.stdout


def measure(
    work: Path, n: int, skip: set[str], links: bool = False, maps_per_rule: int = 8
) -> dict:
    work.mkdir(parents=True, exist_ok=True)
    maps = (link_maps if links else make_maps)(work / "maps", n)
    for extra in sorted((work / "maps").glob("p*.exr"))[n:]:
        extra.unlink()
    (work / "scene.toml").write_text(SCENE)
    out = work / "out"
    res: dict = {"n": n, "maps_per_rule": maps_per_rule}
    shutil.rmtree(out, ignore_errors=True)
    jobs = ["--jobs", "2"] if "--jobs" in subprocess.run(
        [SHBAKE, "plan", "--help"], capture_output=True, text=True).stdout else []  # fmt: skip
    from shbake.batch.plan_cache import store_scene_units

    store_scene_units(str(work / "scene.toml"), {})  # a cold plan: no units of an earlier run
    res["plan"] = run([SHBAKE, "plan", "scene.toml", *jobs, "-q"], work)
    res["bake"] = run([SHBAKE, "bake", "scene.toml", "--jobs", "2", "-q"], work)
    lock = json.loads((out / "scene.lock.json").read_text())
    res["assets"] = len(lock["assets"])
    res["noop_bake"] = run([SHBAKE, "bake", "scene.toml", "--json", "-q"], work)
    again = json.loads(res["noop_bake"]["stdout"])
    res["noop_baked"] = len(again["baked"])
    one = maps[0]
    if links:  # another map's bytes through the link (never written through: shared maps)
        saved = os.readlink(one)
        one.unlink()
        one.symlink_to(os.readlink(maps[1]))
    else:
        saved = one.read_bytes()
        shutil.copy(maps[1], one)  # other bytes: its assets only are out of date
    changed = run([SHBAKE, "bake", "scene.toml", "--json", "-q"], work)
    res["one_map_baked"] = json.loads(changed["stdout"])["baked"]
    if links:
        one.unlink()
        one.symlink_to(saved)
    else:
        one.write_bytes(saved)
    run([SHBAKE, "bake", "scene.toml", "-q"], work)
    baked = {a: r for a, r in lock["assets"].items() if "copy_of" not in r}  # not copies
    res["copies"] = len(lock["assets"]) - len(baked)
    res["check_seconds"] = {
        kind: float(np.mean([r["seconds_with_check"] - r["bake_seconds"]
                             for a, r in baked.items() if a.startswith(kind + "/")]))
        for kind in ("env_sh", "shexp")
    }  # fmt: skip
    res["bake_seconds"] = {
        kind: float(np.mean([r["bake_seconds"] for a, r in baked.items()
                             if a.startswith(kind + "/")]))
        for kind in ("env_sh", "shexp")
    }  # fmt: skip
    res["error_methods"] = sorted({json.dumps(r.get("error_method"))
                                   for r in lock["assets"].values()})  # fmt: skip
    if "bare" not in skip:
        res["bare"] = bare_commands(work, maps, lock)
    if "make" not in skip:
        shutil.rmtree(out)
        grouped = ["--maps-per-rule", str(maps_per_rule)] if many_maps_per_rule() else []
        res["make_plan"] = run([SHBAKE, "plan", "scene.toml", *jobs, "--emit-make", "scene.mk",
                                "--shbake", SHBAKE, *grouped, "-q"], work)  # fmt: skip
        (work / "Makefile").write_text("include scene.mk\n")
        res["make"] = run(["make", "-j2", "scene-assets"], work)
        res["noop_make"] = run(["make", "-j2", "scene-assets"], work)
    if "dask" not in skip:
        import dask
        from distributed import LocalCluster

        from shbake.batch.workers import WARM_MODULE

        # the workers as docs/SCENES.md configures them: the nanny's MALLOC_TRIM_THRESHOLD_
        # unset (~30 % of their CPU), no statistical profiler (~15 %), shbake preloaded
        nanny = {"pre-spawn-environ": {"MALLOC_TRIM_THRESHOLD_": None}}
        worker = {"profile": {"enabled": False}}
        dask.config.update(dask.config.config, {"distributed": {"nanny": nanny,
                                                                "worker": worker}})  # fmt: skip
        shutil.rmtree(out)
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=":0", preload=[WARM_MODULE]) as cluster:  # fmt: skip
            res["dask"] = run([SHBAKE, "bake", "scene.toml", "--scheduler",
                               cluster.scheduler_address, "-q"], work, cluster=True)  # fmt: skip
    for v in res.values():
        if isinstance(v, dict):
            v.pop("stdout", None)
    return res


def report(res: dict) -> str:
    n = res["n"]
    scene = res["plan"]["wall"] + res["bake"]["wall"]
    lines = [f"## N = {n} probes ({res['assets']} assets, {res.get('copies', 0)} written from "
             "the bake of the same map bytes)", "",
             "| run | wall s | CPU s | probes/s | client MiB | worker MiB |",
             "|---|---|---|---|---|---|"]  # fmt: skip

    def row(name, *ms):
        wall = sum(m["wall"] for m in ms)
        cpu = sum(m["cpu"] for m in ms)
        cm = max(m["client_mib"] for m in ms)
        wm = max(m["worker_mib"] for m in ms)
        lines.append(f"| {name} | {wall:.1f} | {cpu:.1f} | {n / wall:.1f} | {cm:.0f} | {wm:.0f} |")

    row("`plan --jobs 2`", res["plan"])
    row("`bake --jobs 2` (cold)", res["bake"])
    row("`plan` + `bake --jobs 2`", res["plan"], res["bake"])
    if "make" in res:  # the fragment's plan found the units `plan` kept: count a cold plan
        per_rule = res.get("maps_per_rule", 8)
        row(f"`plan` + `make -j2` ({per_rule} maps a rule)", res["plan"], res["make"])
    if "dask" in res:
        row("`bake --scheduler` LocalCluster(2)", res["dask"])
    if "bare" in res:
        for k, ms in res["bare"]["parts"].items():
            row(f"bare `{k}` --jobs 2", *ms)
        row("bare commands, total", res["bare"])
    noop = res["noop_bake"]
    lines += ["", f"no-op `bake`: {noop['wall']:.2f} s wall, {noop['cpu']:.2f} s CPU, client "
              f"{noop['client_mib']:.0f} MiB ({res['noop_baked']} baked)"]  # fmt: skip
    if "noop_make" in res:
        lines.append(f"no-op `make -j2`: {res['noop_make']['wall']:.2f} s")
    lines.append(f"one map's bytes changed, `bake` rebaked: {res['one_map_baked']}")
    lines.append("mean per-asset check seconds (lock: with check − bake): "
                 + ", ".join(f"{k} {v:.3f}" for k, v in res["check_seconds"].items())
                 + "; bake seconds: "
                 + ", ".join(f"{k} {v:.3f}" for k, v in res["bake_seconds"].items()))  # fmt: skip
    lines.append(f"error methods in the lock: {', '.join(res['error_methods'])}")
    if "bare" in res:
        bare = res["bare"]["wall"]
        cpu = (res["plan"]["cpu"] + res["bake"]["cpu"]) / res["bare"]["cpu"]
        lines.append(f"plan + bake --jobs 2 / bare: {scene / bare:.2f} wall (acceptance ≤ 1.5), "
                     f"{cpu:.2f} CPU")  # fmt: skip
        if "make" in res:
            mk = res["plan"]["wall"] + res["make"]["wall"]
            lines.append(f"plan + make -j2 / bare: {mk / bare:.2f} (≤ 2)")
    if "dask" in res:
        d = res["dask"]
        lines.append(f"Dask / bake --jobs 2: {d['wall'] / res['bake']['wall']:.2f} wall (≤ 1.2)")
        if "cluster_cpu" in d:
            c = d["cluster_cpu"]
            total = d["cpu"] + c["workers"] + c["scheduler"]
            lines.append(f"Dask CPU: client {d['cpu']:.1f} s, workers {c['workers']:.1f} s, "
                         f"scheduler (with this script's sampling) {c['scheduler']:.1f} s; "
                         f"{total / res['bake']['cpu']:.2f}× `bake --jobs 2`'s CPU")  # fmt: skip
    lines.append(f"end-to-end rate (plan + bake --jobs 2): {n / scene:.1f} probes/s (≥ 25)")
    return "\n".join(lines)


def plot(results: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    series = {"plan + bake --jobs 2": lambda r: r["plan"]["wall"] + r["bake"]["wall"],
              "plan + make -j2": lambda r: r["plan"]["wall"] + r["make"]["wall"],
              "bake --scheduler (Dask, 2 workers)": lambda r: r["dask"]["wall"],
              "bare commands --jobs 2": lambda r: r["bare"]["wall"]}  # fmt: skip
    for name, f in series.items():
        points = []
        for r in results:  # a run with --skip leaves its N out of that series only
            try:
                points.append((r["n"], f(r)))
            except KeyError:
                continue
        if points:
            ax.loglog(*zip(*points, strict=True), "o-", label=name)
    ax.set_xlabel("probes (512×256 maps)")
    ax.set_ylabel("wall seconds (2 cores)")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, action="append")
    p.add_argument("--work", default=None)
    p.add_argument("--plot", default=None)
    p.add_argument("--json", default=None)
    p.add_argument("--skip", default="")
    p.add_argument("--links", action="store_true", help="maps: links to the six shared maps")
    p.add_argument("--maps-per-rule", type=int, default=8, help="the fragment's rules")
    a = p.parse_args()
    work = Path(a.work or tempfile.mkdtemp(prefix="scene-scale-"))
    skip = set(filter(None, a.skip.split(",")))
    results = []
    print(f"load average at start: {os.getloadavg()[0]:.2f}; work folder {work}")
    for n in a.n or [100]:
        folder = work / (f"n{n}-links" if a.links else f"n{n}")
        results.append(measure(folder, n, skip, a.links, a.maps_per_rule))
        print(report(results[-1]), flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=1))
    if a.plot:
        plot(results, a.plot)


def from_json(path: str, plot_path: str | None = None) -> None:
    """The report (and plot) of a run's ``--json`` results, again."""
    results = json.loads(Path(path).read_text())
    for r in results:
        print(report(r))
    if plot_path:
        plot(results, plot_path)


if __name__ == "__main__":
    main()
