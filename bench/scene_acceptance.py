"""Issue 16 acceptance on configs/example-scene.toml (six maps): re-runnable, prints a report.

    .venv/bin/python bench/scene_acceptance.py [SCRATCH_DIR]

1. plan; 2. make -j2 from the emitted fragment; 3. a second make does nothing;
4. touching one map: make -n lists only its assets; 5. bake --jobs 2 and a
2-worker Dask LocalCluster into the same out_dir, bytes compared with make's;
6. measured errors vs tolerances from scene.lock.json; 7. every asset's make
recipe (``shbake bake SCENE --asset ID``) run again, one at a time, its CPU
seconds (getrusage of the child: user + system) against the plan's prediction
(the prediction's meaning: shbake/batch/plan_costs.py), wall seconds and the
load average beside them. CPU time is what is predicted because the machine is
shared: wall time under load is provisional.
"""

import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHBAKE = str(Path(sys.executable).with_name("shbake"))


def hashes(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()
            and ".stamps" not in p.parts and p.name != "scene.lock.json"}  # fmt: skip


def main():
    work = Path(sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="scene-acc-"))
    work.mkdir(parents=True, exist_ok=True)
    (work / "maps").mkdir(exist_ok=True)
    for m in sorted((ROOT / "data_samples").glob("*.exr")):
        shutil.copy(m, work / "maps" / m.name)
    text = (ROOT / "configs" / "example-scene.toml").read_text()
    text = text.replace('out_dir = "../out/example-scene"', 'out_dir = "out"')
    scene = work / "scene.toml"
    scene.write_text(text.replace("../data_samples/", "maps/"))
    out = work / "out"
    shutil.rmtree(out, ignore_errors=True)
    run = lambda *a, **k: subprocess.run(a, cwd=work, check=True, text=True,  # noqa: E731
                                         capture_output=True, **k)  # fmt: skip
    print(run(SHBAKE, "plan", str(scene), "--emit-make", "scene.mk", "--shbake", SHBAKE).stdout)
    (work / "Makefile").write_text("include scene.mk\n")
    run("make", "-j2", "scene-assets")
    by_make = hashes(out)
    q = subprocess.run(["make", "-q", "scene-assets"], cwd=work)
    print(f"second make: {'nothing to do' if q.returncode == 0 else 'WOULD REBUILD'}")
    (work / "maps" / "night.exr").touch()
    dry = run("make", "-n", "scene-assets").stdout
    rebuilt = sorted(ln.split("--asset ")[1].split()[0] for ln in dry.splitlines()
                     if "--asset" in ln)  # fmt: skip
    print(f"after touching maps/night.exr make would rebuild: {rebuilt}")
    run("make", "scene-assets")
    shutil.rmtree(out)
    run(SHBAKE, "bake", str(scene), "--jobs", "2", "-q")
    by_jobs = hashes(out)
    lock = json.loads((out / "scene.lock.json").read_text())
    from distributed import LocalCluster

    shutil.rmtree(out)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster:  # fmt: skip
        run(SHBAKE, "bake", str(scene), "--scheduler", cluster.scheduler_address, "-q")
    by_dask = hashes(out)
    print(f"files: {len(by_make)}; make == --jobs 2: {by_make == by_jobs}; "
          f"make == Dask: {by_make == by_dask}")
    again = json.loads(run(SHBAKE, "bake", str(scene), "--json", "-q").stdout)
    print(f"second bake: {len(again['baked'])} baked, {len(again['skipped'])} up to date")
    print("\nasset                      measured error (tol)")
    for aid, r in sorted(lock["assets"].items()):
        err = ", ".join(f"{v:.3g} ({r['tolerances'].get(k, float('nan')):g})"
                        for k, v in r["measured_error"].items()) or "n/a"  # fmt: skip
        print(f"{aid:26} {err}")
        for k, v in r["measured_error"].items():
            if k in r["tolerances"] and v > r["tolerances"][k]:
                print(f"   !! {aid} {k} {v:.3g} exceeds its tolerance")
    plan = json.loads(run(SHBAKE, "plan", str(scene), "--json", "-q").stdout)
    print(f"\nload average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print("asset                      predicted s  measured CPU s  ratio  wall s")
    ratios = []
    for a in plan["assets"]:
        c0, t0 = _children_cpu(), time.perf_counter()
        run(SHBAKE, "bake", str(scene), "--asset", a["id"], "--quiet")
        cpu, wall = _children_cpu() - c0, time.perf_counter() - t0
        ratios.append(cpu / a["predicted_seconds"])
        print(f"{a['id']:26} {a['predicted_seconds']:11.2f} {cpu:15.2f} {ratios[-1]:6.2f} "
              f"{wall:7.2f}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    within = sum(0.5 <= x <= 2 for x in ratios)
    print(f"\npredicted within 2x of measured CPU: {within}/{len(ratios)} "
          f"(ratios {min(ratios):.2f} … {max(ratios):.2f})")


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime

if __name__ == "__main__":
    main()
