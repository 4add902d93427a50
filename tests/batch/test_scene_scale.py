"""Issue 31: the scene layer at scale — cheap checks that stay honest, plan results carried
to the bake, one decode per map, tasks of several maps.

The cheap checks are compared with the full brute force (every texel, 4096 directions),
computed here by :func:`shbake.reference.irradiance.brute_force_irradiance`, not by the
code under test.
"""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from shbake.batch.project_env import project_environment
from shbake.envmap import load_environment
from shbake.evaluation.env_sh import brute_force_reference, check_reference, irradiance_errors
from shbake.format.asset import read_asset
from shbake.reference.irradiance import brute_force_irradiance
from shbake.reference.irradiance_pyramid import IrradiancePyramid
from shbake.sh.point_sets import fibonacci_sphere
from tests.helpers import DIFFUSE_SCENE, SHARED_MAPS, map_path, write_test_exr


class TestPyramid:
    @pytest.mark.parametrize("name", ["studio", "sunset"])
    def test_is_the_brute_force_sum(self, name):
        """The pyramid reorders the brute-force sum exactly (not an approximation)."""
        env = load_environment(str(map_path(name)), quiet=True)
        q = fibonacci_sphere(300)
        got = IrradiancePyramid(env).irradiance(q)
        ref = brute_force_irradiance(*env.samples(), q)
        assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))

    def test_a_sun_and_a_cube_layout(self, tmp_path):
        """One texel of 1e5 (a sun) on a cube cross: bins of every size, empty texels."""
        px = np.full((96, 128, 3), 0.25, np.float32)  # 4:3 cross, 32-texel faces
        px[40, 50] = 1e5
        path = write_test_exr(tmp_path / "cross.exr", px)
        env = load_environment(str(path), layout="cross-h", quiet=True)
        q = fibonacci_sphere(200)
        got = IrradiancePyramid(env).irradiance(q)
        ref = brute_force_irradiance(*env.samples(), q)
        assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))


@pytest.mark.parametrize("name", SHARED_MAPS)
def test_cheap_check_agrees_with_full_brute_force(name, tmp_path):
    """The scene bake's irradiance check (pyramid, 256 directions) against the full brute
    force (every texel, 4096 directions): the measured relative RMS errors agree within
    10 % of the error itself, sun kept and extracted, lmax 2 and 4."""
    env = load_environment(str(map_path(name)), quiet=True)
    full = brute_force_reference(env, 4096, names=("irradiance",))
    for sun in (False, True):
        for lmax in (2, 4):
            out = str(tmp_path / f"{sun}{lmax}.h5")
            project_environment(str(map_path(name)), out, lmax=lmax, irradiance_lmax=lmax,
                                tangent_irradiance=False, extract_sun=sun,
                                quiet=True)  # fmt: skip
            asset = read_asset(out)
            cheap = irradiance_errors(asset, env, check_reference(env, ["irradiance"]))
            exact = irradiance_errors(asset, env, full)
            a, b = cheap["irradiance"]["relative_rms"], exact["irradiance"]["relative_rms"]
            assert abs(a - b) <= 0.1 * b, (name, sun, lmax, a, b)


def diffuse_scene(folder: Path, names=("studio", "sunset")) -> Path:
    (folder / "maps").mkdir()
    for n in names:
        shutil.copy(map_path(n), folder / "maps" / f"{n}.exr")
    path = folder / "scene.toml"
    path.write_text(DIFFUSE_SCENE)
    return path


def test_lock_says_how_errors_were_measured_and_no_tangent_is_computed(tmp_path, monkeypatch):
    """Each record names its error's method; an asset without tangent irradiance computes
    none (the brute force once computed both for every env_sh asset)."""
    import shbake.reference.irradiance as reference
    from shbake.batch.scene import load_scene
    from shbake.batch.scene_bake import bake_scene

    calls = []
    real = reference.brute_force_irradiance

    def spy(dirs, omega, radiance, normals, tangent=False):
        calls.append(tangent)
        return real(dirs, omega, radiance, normals, tangent)

    monkeypatch.setattr(reference, "brute_force_irradiance", spy)
    import shbake.evaluation.env_sh as env_sh

    monkeypatch.setattr(env_sh, "brute_force_irradiance", spy)
    scene = load_scene(str(diffuse_scene(tmp_path)))
    bake_scene(scene)
    lock = json.loads((tmp_path / "out" / "scene.lock.json").read_text())
    assert set(lock["assets"]) == {"env_sh/studio", "env_sh/sunset"}
    for rec in lock["assets"].values():
        assert rec["error_method"] == {"irradiance": "direction-set-pyramid"}
        assert set(rec["measured_error"]) == {"irradiance"}
    assert not any(calls), "tangent irradiance was summed for assets that have none"


def test_env_sh_check_measures_the_written_asset_without_reading_it_back(tmp_path, monkeypatch):
    """The env_sh check takes the asset from memory (reading each file back cost a quarter of
    an env_sh bake): no asset is read during the bake, and each lock error equals the one
    measured afresh from the file on disk (the map turned by a probe pose included)."""
    import shbake.format.asset as asset_module
    from shbake.batch.scene import load_scene
    from shbake.batch.scene_bake import bake_scene
    from shbake.envmap.turn import turn_matrix

    path = diffuse_scene(tmp_path)
    path.write_text(DIFFUSE_SCENE.replace('"maps/*.exr"', '"maps/*.exr"\nrotation_deg = 30.0'))
    reads = []
    real = asset_module.read_asset
    monkeypatch.setattr(
        asset_module, "read_asset", lambda *a, **k: reads.append(a) or real(*a, **k)
    )
    bake_scene(load_scene(str(path)))
    assert reads == []
    lock = json.loads((tmp_path / "out" / "scene.lock.json").read_text())
    for aid, rec in lock["assets"].items():
        name = aid.split("/")[-1]
        asset = real(str(tmp_path / "out" / aid) + ".h5")
        env = load_environment(str(map_path(name)), quiet=True)
        ref = check_reference(env, ["irradiance"])
        turn = turn_matrix(rec["settings"]["pose"]["rotation_deg"])
        fresh = irradiance_errors(asset, env, ref, rotation=turn)["irradiance"]["relative_rms"]
        assert rec["measured_error"]["irradiance"] == fresh, aid


def test_workers_plan_each_map_content_once(tmp_path, monkeypatch):
    """``plan --jobs``: a map linked or copied under other names is planned once, not once
    per worker task it falls in (a 10,000-probe scene of links to a few maps)."""
    import contextlib

    import shbake.batch.plan as plan
    import shbake.batch.workers as workers
    from shbake.batch.scene import load_scene

    path = diffuse_scene(tmp_path)
    (tmp_path / "maps" / "again.exr").symlink_to(tmp_path / "maps" / "studio.exr")
    shutil.copy(map_path("studio"), tmp_path / "maps" / "copy.exr")
    monkeypatch.setattr(plan, "PLAN_POOL_MAPS", 1)
    monkeypatch.setattr(plan, "PLAN_TASK_MAPS", 1)
    # the workers' tasks run here, in order, so that their measurements can be counted
    here = type("Pool", (), {"map": map})
    monkeypatch.setattr(workers, "worker_pool", lambda jobs: contextlib.nullcontext(here))
    measured = []
    real = plan.plan_env_sh
    monkeypatch.setattr(plan, "plan_env_sh", lambda *a, **k: measured.append(a[0]) or real(*a, **k))
    result = plan.plan_scene_kept(load_scene(str(path)), jobs=2)
    assert len(result["assets"]) == 4
    assert len(measured) == 2, measured  # studio (or a link or copy of it) and sunset


def test_stamps_compared_by_value_without_indenting(tmp_path, monkeypatch):
    """A bake with nothing to do writes no stamp and indents no JSON (the pure-Python encoder
    was ~1 s of a 2000-asset no-op bake); a stamp whose value differs, if only in a number's
    type, is written again with the text the first bake wrote."""
    import shbake.batch.scene_bake as scene_bake
    from shbake.batch.scene import load_scene

    scene = load_scene(str(diffuse_scene(tmp_path)))
    scene_bake.bake_scene(scene)
    stamp = tmp_path / "out" / ".stamps" / "env_sh" / "studio.json"
    text = stamp.read_text()
    lmax = json.loads(text)["settings"]["lmax"]
    assert isinstance(lmax, int)
    stamp.write_text(text.replace(f'"lmax": {lmax}', f'"lmax": {lmax}.0'))
    indented = []
    real = scene_bake.settings_text
    monkeypatch.setattr(scene_bake, "settings_text", lambda a: indented.append(a) or real(a))
    summary = scene_bake.bake_scene(scene)
    assert summary["baked"] == []
    assert [a["id"] for a in indented] == ["env_sh/studio"]
    assert stamp.read_text() == text


def test_bake_after_plan_does_not_plan_again(tmp_path, monkeypatch):
    """``plan`` keeps its per-unit plans; a bake from a cold output folder reuses them."""
    import shbake.batch.plan as plan
    from shbake.batch.scene import load_scene
    from shbake.batch.scene_bake import bake_scene

    scene = load_scene(str(diffuse_scene(tmp_path)))
    first = plan.plan_scene_kept(scene)
    measured = []
    real = plan.plan_env_sh
    monkeypatch.setattr(plan, "plan_env_sh", lambda *a, **k: measured.append(a) or real(*a, **k))
    summary = bake_scene(scene)
    assert measured == []
    assert sorted(summary["baked"]) == sorted(a["id"] for a in first["assets"])


def test_bake_decodes_each_map_once(tmp_path, monkeypatch):
    """A bake reads each map's pixels once for its assets and their checks."""
    import shbake.envmap.environment as environment
    from shbake.batch.scene import load_scene
    from shbake.batch.scene_bake import bake_scene

    reads = []
    real = environment.read_image
    monkeypatch.setattr(environment, "read_image", lambda p: reads.append(p) or real(p))
    text = DIFFUSE_SCENE + '[[materials]]\nname = "v"\nkind = "glossy"\nroughness = [0.5, 0.9]\n'
    path = diffuse_scene(tmp_path, ("studio",))
    path.write_text(text)
    scene = load_scene(str(path))
    from shbake.batch.plan import plan_scene_kept

    plan_scene_kept(scene)
    reads.clear()
    summary = bake_scene(scene)
    assert len(summary["baked"]) == 2  # env_sh and a glossy probe, each checked
    assert len(reads) == 1


def test_decoded_once_sees_changed_bytes(tmp_path):
    """Within a scope a file rewritten (other size or time) is decoded again; each caller
    gets its own pixels."""
    from shbake.envmap.environment import decoded_once

    path = tmp_path / "m.exr"
    write_test_exr(path, np.full((8, 16, 3), 1.0))
    with decoded_once():
        a = load_environment(str(path), quiet=True)
        a.pixels[:] = 7.0
        b = load_environment(str(path), quiet=True)
        assert np.all(b.pixels == 1.0)
        write_test_exr(path, np.full((16, 32, 3), 2.0))
        c = load_environment(str(path), quiet=True)
        assert c.shape == (16, 32) and np.all(c.pixels == 2.0)


def test_chunks_keep_a_maps_assets_together():
    from shbake.batch.scene_bake import chunks

    wave = [{"id": f"{k}/m{i}", "kind": k, "inputs": [f"m{i}.exr"]}
            for i in range(5) for k in ("env_sh", "shexp")]  # fmt: skip
    wave.append({"id": "brdf_table/x", "kind": "brdf_table", "inputs": []})
    tasks = chunks(wave, maps=2)
    assert [len(t) for t in tasks] == [4, 4, 3]
    assert [a for t in tasks for a in t] == wave
    for t in tasks:
        maps = {a["inputs"][0] for a in t if a["inputs"]}
        assert len(maps) <= 2


def _same_asset(a: Path, b: Path) -> None:
    """Every dataset and attribute equal, but what provenance records of the run."""
    import h5py

    run_attrs = {"command_line", "source_path"}
    with h5py.File(a) as fa, h5py.File(b) as fb:
        items = []
        fa.visititems(lambda name, obj: items.append(name))
        for name in [""] + items:
            oa, ob = fa[name] if name else fa, fb[name] if name else fb
            assert set(oa.attrs) == set(ob.attrs)
            for k in set(oa.attrs) - run_attrs:
                assert np.array_equal(np.asarray(oa.attrs[k]), np.asarray(ob.attrs[k])), (name, k)
            if isinstance(oa, h5py.Dataset):
                assert np.array_equal(oa[()], ob[()]), name


@pytest.mark.parametrize("command, options", [
    ("project-env", ["--extract-sun", "--no-tangent-irradiance"]),
    ("split-sum", ["--size", "32", "--min-size", "16", "--samples", "64"]),
])  # fmt: skip
def test_many_maps_in_one_call(command, options, tmp_path):
    """``--out-dir``/``--jobs``/``--list``: each map's asset is the one-map command's."""
    import subprocess
    import sys

    shbake = str(Path(sys.executable).with_name("shbake"))
    names = ("city", "night", "studio")
    (tmp_path / "list.txt").write_text(f"{map_path('sunset')} named.h5\n")
    maps = [str(map_path(n)) for n in names]
    subprocess.run([shbake, command, *maps, "--list", str(tmp_path / "list.txt"), "--out-dir",
                    str(tmp_path / "many"), "--jobs", "2", "-q", *options], check=True)  # fmt: skip
    assert sorted(p.name for p in (tmp_path / "many").iterdir()) == [f"{n}.h5" for n in names]
    for name, src in [*zip(names, maps, strict=True), ("named", str(map_path("sunset")))]:
        one = tmp_path / f"one-{name}.h5"
        subprocess.run([shbake, command, src, "-o", str(one), "-q", *options], check=True)
        many = tmp_path / ("named.h5" if name == "named" else f"many/{name}.h5")
        _same_asset(one, many)


def test_many_maps_refused_before_any_work(tmp_path):
    """Two maps that would write one file: one line, non-zero, nothing written."""
    import subprocess
    import sys

    shbake = str(Path(sys.executable).with_name("shbake"))
    (tmp_path / "a").mkdir()
    shutil.copy(map_path("city"), tmp_path / "a" / "city.exr")
    done = subprocess.run([shbake, "project-env", str(map_path("city")),
                           str(tmp_path / "a" / "city.exr"), "--out-dir", str(tmp_path / "o")],
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode != 0
    assert done.stderr.count("\n") == 1 and "two maps would write" in done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]


def test_grouped_make_rules_rebake_exactly_what_changed(tmp_path):
    """``plan --emit-make --maps-per-rule 2``: one rule (one process) for two maps' assets,
    the same bytes as ``bake``; a touched map rebakes only its own assets."""
    import os
    import subprocess
    import sys

    shbake = str(Path(sys.executable).with_name("shbake"))
    path = diffuse_scene(tmp_path, ("studio", "sunset", "night"))
    run = lambda *a: subprocess.run(a, cwd=tmp_path, check=True, capture_output=True,  # noqa: E731
                                    text=True)  # fmt: skip
    run(shbake, "plan", path.name, "--emit-make", "scene.mk", "--shbake", shbake,
        "--maps-per-rule", "2", "-q")  # fmt: skip
    fragment = (tmp_path / "scene.mk").read_text()
    assert fragment.count("&:") == 1 and fragment.count("\t$(SHBAKE) bake") == 2
    (tmp_path / "Makefile").write_text("include scene.mk\n")
    run("make", "-j2", "scene-assets")
    out = tmp_path / "out" / "env_sh"
    by_make = {p.name: p.read_bytes() for p in out.iterdir()}
    assert subprocess.run(["make", "-q", "scene-assets"], cwd=tmp_path).returncode == 0
    later = os.stat(out / "sunset.h5").st_mtime + 100
    os.utime(tmp_path / "maps" / "studio.exr", (later, later))  # newer: its asset only
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    run("make", "scene-assets")
    after = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert [n for n in sorted(after) if after[n] != before[n]] == ["studio.h5"]
    shutil.rmtree(tmp_path / "out")
    run(shbake, "bake", path.name, "-q")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == by_make


def test_two_workers_with_their_own_folders(tmp_path):
    """A scheduler and two ``dask worker`` processes, each started in a working directory
    (and ``--local-directory``) of its own, as on two machines: ``bake --scheduler`` writes
    the same bytes as a local bake, every file written by the client, none in the
    workers' folders; a probe on a link to another's map is written from that bake on a
    worker that has only the bytes the client sent (:func:`scene_bake.same_work`). One
    worker starts as docs/SCENES.md recommends, ``--preload shbake.batch.warm_worker``: shbake
    and numba loaded before any task."""
    import json as json_
    import subprocess
    import sys
    import time

    bin_dir = Path(sys.executable).parent
    shbake, dask = str(bin_dir / "shbake"), str(bin_dir / "dask")
    (tmp_path / "scene").mkdir()
    scene = diffuse_scene(tmp_path / "scene", ("studio", "sunset", "night"))
    (tmp_path / "scene" / "maps" / "linked.exr").symlink_to("studio.exr")
    info = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--dashboard-address", ":0", "--scheduler-file", str(info)],
                              cwd=tmp_path, stderr=subprocess.DEVNULL)]  # fmt: skip
    try:
        workers = []
        for i in range(2):
            folder = tmp_path / f"worker{i}"
            folder.mkdir()
            workers.append(folder)
            preload = ["--preload", "shbake.batch.warm_worker"] if i else []
            procs.append(subprocess.Popen(
                [dask, "worker", "--scheduler-file", str(info), "--nthreads", "1",
                 "--local-directory", str(folder), "--no-dashboard", *preload],
                cwd=folder, stderr=subprocess.DEVNULL))  # fmt: skip
        deadline = time.time() + 120
        while time.time() < deadline:
            if info.exists():
                from distributed import Client

                with Client(scheduler_file=str(info), timeout=60) as client:
                    client.wait_for_workers(2, timeout=120)
                    address = client.scheduler.address
                    loaded = client.run(lambda: {m for m in ("numba", "shbake.batch.plan")
                                                 if m in sys.modules})  # fmt: skip
                assert sorted(map(len, loaded.values())) == [0, 2], loaded
                break
            time.sleep(0.5)
        done = subprocess.run([shbake, "bake", str(scene), "--scheduler", address, "--json",
                               "-q"], capture_output=True, text=True)  # fmt: skip
        assert done.returncode == 0, done.stderr
        assert len(json_.loads(done.stdout)["baked"]) == 4
        lock = json_.loads((tmp_path / "scene" / "out" / "scene.lock.json").read_text())
        copies = {a: r["copy_of"] for a, r in lock["assets"].items() if "copy_of" in r}
        assert copies == {"env_sh/studio": "env_sh/linked"}  # the glob's order: linked first
        out = tmp_path / "scene" / "out" / "env_sh"
        by_dask = {p.name: p.read_bytes() for p in out.iterdir()}
        for folder in workers:
            assert not [p for p in folder.rglob("*.h5")], folder
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(30)
    shutil.rmtree(tmp_path / "scene" / "out")
    subprocess.run([shbake, "bake", str(scene), "-q"], check=True)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == by_dask


def test_file_hash_sees_a_rewritten_file(tmp_path):
    """The per-process hash memo never serves old bytes: a file rewritten in place (same
    size) or replaced is hashed again (against hashlib here)."""
    import hashlib
    import os

    from shbake.batch.plan import file_hash

    path = tmp_path / "m.bin"
    for data in (b"a" * 64, b"b" * 64, b"c" * 65):
        path.write_bytes(data)
        assert file_hash(str(path)) == hashlib.sha256(data).hexdigest()
    other = tmp_path / "n.bin"
    other.write_bytes(b"d" * 65)
    os.replace(other, path)
    assert file_hash(str(path)) == hashlib.sha256(b"d" * 65).hexdigest()


def test_file_hash_reads_a_file_once_by_every_name(tmp_path, monkeypatch):
    """Links (symbolic and hard) to one file are one file: read once (10,000 probes on six
    maps hash six files), each name still recorded as an input of the run."""
    import hashlib
    import os

    from shbake import resources
    from shbake.batch.plan import file_hash

    path = tmp_path / "m.bin"
    path.write_bytes(b"map bytes")
    (tmp_path / "soft.bin").symlink_to("m.bin")
    os.link(path, tmp_path / "hard.bin")
    reads, noted = [], []
    real_sha, real_note = resources.sha256_of, resources.note_input
    monkeypatch.setattr(resources, "sha256_of", lambda p, o: reads.append(p) or real_sha(p, o))
    monkeypatch.setattr(resources, "note_input", lambda p: noted.append(p) or real_note(p))
    names = [str(tmp_path / n) for n in ("m.bin", "soft.bin", "hard.bin")]
    assert {file_hash(n) for n in names} == {hashlib.sha256(b"map bytes").hexdigest()}
    assert reads == names[:1] and noted == names


def test_lock_text_is_the_lock():
    """One line per record, and json reads back exactly the lock."""
    from shbake.batch.scene_bake import lock_text

    lock = {"scene": "s.toml", "assets": {"b/x": {"z": [1.5, None], "a": {"k": "é"}},
                                          "a/y": {}}, "plans": {}}  # fmt: skip
    text = lock_text(lock)
    assert json.loads(text) == lock
    assert text.splitlines()[2].startswith('  "a/y"') and len(text.splitlines()) == 8


PROBE_SCENE = """[scene]
out_dir = "out"
[tolerances]
glossy_probe = 0.3
{environments}
[[materials]]
name = "plaster"
kind = "diffuse"
[[materials]]
name = "varnish"
kind = "glossy"
roughness = [0.5, 0.9]
"""


def probe_scene(folder: Path, probes: dict[str, list[float]], pixels) -> Path:
    """A scene of one probe per ``name → position``: ``maps/NAME.exr``, the first a file of
    ``pixels``, the others symbolic links to it; diffuse + glossy (env_sh + a glossy probe)."""
    (folder / "maps").mkdir(parents=True)
    entries = []
    for i, (name, position) in enumerate(probes.items()):
        if i == 0:
            write_test_exr(folder / "maps" / f"{name}.exr", pixels)
        else:
            (folder / "maps" / f"{name}.exr").symlink_to(f"{next(iter(probes))}.exr")
        entries.append(f'[[environments]]\nmap = "maps/{name}.exr"\nposition = {position}\n')
    path = folder / "scene.toml"
    path.write_text(PROBE_SCENE.format(environments="".join(entries)))
    return path


def test_same_map_bytes_and_settings_baked_once(tmp_path, monkeypatch):
    """Two probes on links to one map (other positions): each asset kind's baker runs once,
    the other probe's assets are written from its bake, and every output has the bytes of a
    scene of that probe alone; the copy's lock record is complete, names what it copies,
    and its error is the one its own bake measures."""
    from collections import defaultdict

    from shbake.batch import plan, scene_bake
    from shbake.batch.scene import load_scene

    # predicted recipe times are not compared: no fresh processes to time them in
    monkeypatch.setattr(plan, "recipe_overheads", lambda classes: defaultdict(float))
    rng = np.random.default_rng(5)
    pixels = rng.uniform(0.1, 2.0, (32, 64, 3)).astype(np.float32)
    both = probe_scene(tmp_path / "both", {"a": [1.0, 2.0, 3.0], "b": [4.0, 5.0, 6.0]}, pixels)
    alone = {n: probe_scene(tmp_path / n, {n: p}, pixels)
             for n, p in (("a", [1.0, 2.0, 3.0]), ("b", [4.0, 5.0, 6.0]))}  # fmt: skip
    single = {n: scene_bake.bake_scene(load_scene(str(p))) for n, p in alone.items()}
    baked = []

    def counted(baker):
        return lambda a, measure=True: baked.append(a["output"]) or baker(a, measure)

    for kind, baker in scene_bake.BAKERS.items():
        monkeypatch.setitem(scene_bake.BAKERS, kind, counted(baker))
    summary = scene_bake.bake_scene(load_scene(str(both)))
    out = tmp_path / "both" / "out"
    kinds = sorted(aid.split("/")[0] for aid in summary["baked"] if aid.endswith("/a"))
    assert len(kinds) == 2 and sorted(summary["baked"]) == sorted(
        f"{k}/{n}" for k in kinds for n in "ab")  # fmt: skip
    assert sorted(p for p in baked if p.startswith(str(out))) == sorted(
        str(out / k / "a.h5") for k in kinds)  # fmt: skip
    for n in "ab":
        for k in kinds:
            own = tmp_path / n / "out" / k / f"{n}.h5"
            assert (out / k / f"{n}.h5").read_bytes() == own.read_bytes(), (k, n)
    lock = json.loads((out / "scene.lock.json").read_text())["assets"]
    for k in kinds:
        copy, own = lock[f"{k}/b"], single["b"]["records"][f"{k}/b"]
        assert copy["copy_of"] == f"{k}/a" and "copy_of" not in lock[f"{k}/a"]
        assert copy["measured_error"] == own["measured_error"]
        assert copy["error_method"] == own["error_method"]
        assert copy["inputs"] == {"maps/b.exr": own["inputs"][next(iter(own["inputs"]))]}
        assert copy["outputs"] == {"b.h5": own["outputs"]["b.h5"]}
    assert scene_bake.bake_scene(load_scene(str(both)))["baked"] == []
