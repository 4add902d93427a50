"""``shbake plan --emit-make`` (issue 27): no scene text reaches make or ``sh`` but as itself.

The property tests draw every name and path a scene brings into the fragment (the scene
file's folder and name, a map's folder and file name, ``out_dir``, environment, material
and scene names, the fragment's name, the ``--shbake`` words) from all of printable
ASCII, tab, newline, CR and non-ASCII characters, write the scene and the fragment
(without planning: the plan is built here from the drawn names) and check, against GNU
make and ``/bin/sh`` themselves:

* a name outside docs/SCENES.md's pattern, or a path or word outside its Makefile safe
  set, is refused in one line and nothing is written;
* otherwise every command ``make -n`` prints is exactly the expected argv (read with the
  POSIX grammar of bare words and single quotes only: anything else ``sh`` would
  interpret fails the test), for every asset rule and the fragment's self-remake rule,
  each path relative to the fragment's folder where make runs (issue 32), and the one
  query of ``$(SHBAKE) --version`` each reading of the fragment makes;
  make finds each target and prerequisite as the very file it names (``make -q`` after
  the outputs exist; touching the map rebuilds exactly its assets);
* ``make`` itself, run with ``SHELL`` a logging wrapper and the command a recorder of its
  argv, starts one shell per recipe and the recorder gets exactly the expected argv.
"""

import os
import re
import shlex
import shutil
import string
import subprocess
import tempfile
import time
import unicodedata
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st
from shbake_cli.guard import message_of

from shbake import __version__
from shbake.batch.scene import load_scene
from shbake.batch.scene_bake import emit_make
from shbake.errors import ParameterError

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="GNU make not installed")

NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}")
"""docs/SCENES.md: environment and material names."""
MAKE_UNSAFE = set(";=|%\\()")
"""docs/SCENES.md: characters no path in a Makefile fragment may hold (with control ones)."""

NON_PRINTABLE_ASCII = "".join(chr(c) for c in range(0x20) if chr(c) not in "\t\n\r") + "\x7f"
WILD = st.text(
    st.characters(exclude_characters=NON_PRINTABLE_ASCII + "/", exclude_categories=("Cs",)),
    min_size=1,
    max_size=8,
)
"""File names of printable ASCII, tab, newline, CR and non-ASCII (C1 controls too)."""
MAKEABLE = st.text(
    st.characters(
        min_codepoint=0x20,
        exclude_characters="/" + "".join(MAKE_UNSAFE),
        exclude_categories=("Cc", "Cs"),
    ),
    min_size=1,
    max_size=8,
)
"""File names a fragment may hold (docs/SCENES.md): most characters make and sh treat
specially (space, '#', '$', ':', quotes, '*?[', '&', '!', '`'…) are in them."""
SAFE_NAME = st.text(
    st.sampled_from(string.ascii_letters + string.digits + "_.-"), min_size=1, max_size=8
).filter(lambda s: s[0] not in ".-")


def weighted(*choices):
    """One of the strategies, each drawn about as often as it is listed (``st.one_of``
    weighs distinct strategies, not repeats)."""
    return st.sampled_from(choices).flatmap(lambda s: s)


def segments():
    """A file name: wild, one a fragment may hold (most often), or a plain one."""
    return weighted(WILD, MAKEABLE, MAKEABLE, MAKEABLE, SAFE_NAME).filter(
        lambda s: s not in (".", "..")
    )


def names():
    """An environment or material name: mostly valid, sometimes wild."""
    return weighted(SAFE_NAME, SAFE_NAME, SAFE_NAME, SAFE_NAME, WILD)


def _control(text: str) -> bool:
    return any(unicodedata.category(c) in ("Cc", "Cs") for c in text)


def makeable(path: str) -> bool:
    """What docs/SCENES.md promises a fragment can name."""
    return not (_control(path) or set(path) & MAKE_UNSAFE or path.endswith(" "))


def named(path: Path, folder: Path) -> str:
    """``path`` as docs/SCENES.md says the fragment names it: relative to the fragment's
    folder ``folder``, ``./`` before a name starting with ``-`` or ``~``."""
    rel = os.path.relpath(path, folder)
    return "./" + rel if rel[0] in "-~" else rel


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string."""
    out = []
    for c in text:
        if c in '"\\':
            out.append("\\" + c)
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04x}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def sh_words(line: str) -> list[str]:
    """The argv ``sh`` runs for ``line``, for lines made of bare words of characters that
    are never special to ``sh`` and of single-quoted strings (inside which ``sh`` reads
    every character as itself) only; any other character fails the test."""
    words, word, i = [], None, 0
    token = re.compile(r"[A-Za-z0-9_./+,:@%-]+|'[^']*'|\\'")
    while i < len(line):
        if line[i] == " ":
            if word is not None:
                words.append(word)
            word, i = None, i + 1
            continue
        m = token.match(line, i)
        assert m, f"sh would interpret {line[i]!r} in {line!r}"
        t = m.group()
        word = (word or "") + (t[1:-1] if t[0] == "'" else "'" if t == "\\'" else t)
        i = m.end()
    if word is not None:
        words.append(word)
    return words


class Layout:
    """A scene, its map and fragment, laid out under a fresh folder from drawn names."""

    def __init__(self, root: Path, d):
        self.root = root
        self.folder = root / d["folder"]
        self.scene = self.folder / (d["scene"] + ".toml")
        self.map = self.folder / d["map_folder"] / (d["map"] + ".exr")
        self.out = self.folder / d["out_dir"]
        self.fragment = self.folder / d["fragment"]
        self.env = d["env"] if d["env"] is not None else d["map"]
        self.materials = d["materials"]
        self.shbake = d["shbake"]
        self.map.parent.mkdir(parents=True)
        self.map.write_bytes(b"")
        lines = [f"[scene]\nname = {toml_string(d['name'])}\nout_dir = "
                 f"{toml_string(d['out_dir'])}\nexports = [\"threejs\"]",
                 '[[environments]]\nmap = "*/*.exr"']  # fmt: skip
        if d["env"] is not None:
            lines.append(f"name = {toml_string(d['env'])}")
        lines.append(f'[[materials]]\nname = {toml_string(self.materials[0])}\nkind = "diffuse"')
        lines.append(f"[[materials]]\nname = {toml_string(self.materials[1])}\n"
                     'kind = "anisotropic"\nmodel = "ashikhmin-shirley"\n'
                     "params = { nu = 4, nv = 1 }")  # fmt: skip
        self.scene.write_text("\n".join(lines) + "\n", encoding="utf-8")
        for p in (self.scene, self.map):  # older than the fragment: no self-remake
            os.utime(p, (1e9, 1e9))

    def outputs(self) -> dict[str, str]:
        """Asset id → output path, as docs/SCENES.md places them."""
        out = str(self.out)
        return {f"env_sh/{self.env}": f"{out}/env_sh/{self.env}.h5",
                f"export/threejs/{self.env}": f"{out}/export/threejs/{self.env}/files.json",
                f"brdf_table/{self.materials[1]}":
                    f"{out}/brdf_table/{self.materials[1]}.h5"}  # fmt: skip

    def plan(self) -> dict:
        """The plan ``plan_scene`` would make of the scene's assets (settings left out)."""
        ids = self.outputs()
        env_sh, export, table = ids
        inputs = {env_sh: [str(self.map)], export: [str(self.map), ids[env_sh]], table: []}
        kinds = {env_sh: "env_sh", export: "export", table: "brdf_table"}
        assets = [{"id": a, "kind": kinds[a], "output": ids[a], "inputs": inputs[a],
                   "input_hashes": {}, "settings": {}} for a in ids]  # fmt: skip
        return {"out_dir": str(self.out), "assets": assets}

    def refusal_expected(self) -> bool:
        names = [self.env, *self.materials]
        paths = [named(p, self.folder) for p in (self.scene, self.map, self.out / ".stamps",
                                                 self.fragment)]  # fmt: skip
        words = shlex.split(self.shbake)
        bad_words = _control(self.shbake) or any("\\" in w for w in words)
        stdin = self.fragment.name == "-"  # make reads a makefile named "-" from stdin
        return (not all(map(NAME.fullmatch, names)) or not all(map(makeable, paths))
                or bad_words or stdin)  # fmt: skip

    def nothing_written(self) -> bool:
        return not (self.fragment.exists() or self.out.exists())


def layouts(shbake_words=None):
    """Drawn layouts; ``shbake_words``: the strategy of the ``--shbake`` words."""
    words = st.lists(segments(), min_size=1, max_size=3) if shbake_words is None else shbake_words
    return st.fixed_dictionaries({
        "folder": segments(), "scene": segments(), "map_folder": segments(),
        "map": segments(), "out_dir": segments(), "fragment": segments(),
        "env": weighted(names(), names(), names(), st.none()), "name": WILD,
        "materials": st.lists(names(), min_size=2, max_size=2, unique=True),
        "shbake": words.map(shlex.join),
    }).filter(lambda d: d["map_folder"][0] != "." != d["map"][0]  # "*/*.exr" skips hidden files
              and len({d["folder"] + "/", d["map_folder"], d["out_dir"], d["fragment"],
                       d["scene"] + ".toml"} - {d["folder"] + "/"}) == 4)  # fmt: skip


def make(layout: Layout, *args, shell=None, env=None) -> subprocess.CompletedProcess:
    """GNU make on the fragment alone (``-f``), in the scene's folder, C locale."""
    cmd = ["make", "--no-print-directory", "-f", named(layout.fragment, layout.folder), *args]
    if shell is not None:
        cmd.append(f"SHELL={shell}")
    full_env = {"PATH": os.environ["PATH"], "LC_ALL": "C", **(env or {})}
    return subprocess.run(cmd, cwd=layout.folder, capture_output=True, text=True,
                          env=full_env, timeout=60)  # fmt: skip


def emitted(d) -> Layout | None:
    """Lay out ``d``, load its scene and emit the fragment; ``None`` when refused (then
    checked: one line, and nothing written)."""
    layout = Layout(Path(tempfile.mkdtemp(prefix="shbake-make-")), d)
    try:
        scene = load_scene(str(layout.scene))
        emit_make(scene, layout.plan(), str(layout.fragment), layout.shbake)
    except ParameterError as e:  # SceneError, MakeNameError
        event(f"refused: {type(e).__name__}")
        assert layout.refusal_expected(), f"refused a safe scene: {e}"
        assert "\n" not in message_of(e) and "\r" not in message_of(e)
        assert layout.nothing_written()
        shutil.rmtree(layout.root)
        return None
    assert not layout.refusal_expected(), "accepted what docs/SCENES.md says it refuses"
    event("accepted")
    return layout


def expected_bake(layout: Layout, words: list[str]) -> list[list[str]]:
    return sorted([*words, "bake", named(layout.scene, layout.folder), "--asset", a, "--quiet"]
                  for a in layout.outputs())  # fmt: skip


VERSION_QUERY = " --version 2>/dev/null"
"""How the fragment's command line asking ``$(SHBAKE)`` its version ends."""
SHELL_RECORDER = f"""#!/bin/sh
# make's SHELL: records each command line it is given (NUL-terminated), runs nothing but
# answers the fragment's version query as shbake {__version__} would
printf '%s\\0' "$2" >> "$0.log"
case "$2" in *'{VERSION_QUERY}') echo "shbake, version {__version__}";; esac
"""


def version_queries(shells: list[str], words: list[str]) -> list[str]:
    """``shells`` less the fragment's version queries, each checked to be exactly
    ``$(SHBAKE) --version`` (at least one: make read the fragment)."""
    queries = [line for line in shells if line.endswith(VERSION_QUERY)]
    assert queries and all(sh_words(q.removesuffix(VERSION_QUERY)) == words
                           for q in queries), queries  # fmt: skip
    return [line for line in shells if not line.endswith(VERSION_QUERY)]


SETTINGS = dict(
    deadline=None,
    database=None,
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
"""Every example starts make: no deadline, and no shrinking (minutes per failure)."""


def check_dry_runs(layout: Layout) -> None:
    """``make -n``: the argv of every rule; make finds each file the fragment names."""
    words = shlex.split(layout.shbake)
    shell = layout.root / "sh-record"
    shell.write_text(SHELL_RECORDER)
    shell.chmod(0o755)
    log = layout.root / "sh-record.log"
    # the scene, newer ("what if"): make runs the fragment's self-remake recipe (even with
    # -n: a makefile is remade before it is read), then prints every asset's
    scene = named(layout.scene, layout.folder)
    dry = make(layout, "-n", "-W", scene, "scene-assets", shell=shell)
    assert dry.returncode == 0, dry.stderr
    remake = [*words, "plan", scene, "--emit-make", named(layout.fragment, layout.folder),
              "--shbake", layout.shbake, "--quiet"]  # fmt: skip
    shells = version_queries(log.read_text().split("\0")[:-1], words)
    assert [sh_words(line) for line in shells] == [remake]
    lines = [sh_words(line) for line in dry.stdout.split("\n") if line]
    assert sorted(lines) == sorted(expected_bake(layout, words) + [remake])
    # every output present and newer than its inputs: make has nothing to do, so each
    # target and prerequisite it read is the file the fragment names
    later = time.time() + 100  # explicit times: file systems stamp in ticks of milliseconds
    for path in layout.outputs().values():
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_bytes(b"")
        os.utime(path, (later, later))
    assert make(layout, "-q", "scene-assets", shell=shell).returncode == 0
    # the map, newer: exactly its assets (not the BRDF table's)
    os.utime(layout.map, (later + 10, later + 10))
    again = make(layout, "-n", "scene-assets", shell=shell)
    got = sorted(w[w.index("--asset") + 1] for w in map(sh_words, again.stdout.split("\n")) if w)
    assert got == sorted(a for a in layout.outputs() if not a.startswith("brdf_table/"))
    shells = version_queries(log.read_text().split("\0")[:-1], words)
    assert len(shells) == 1, "make started another shell"


@pytest.mark.heavy
@pytest.mark.parametrize("examples", [500, pytest.param(10000, marks=pytest.mark.slow)])
def test_make_dry_run_argv_exact(examples):
    """``make -n`` of fragments of drawn scenes (module docstring): 500 of them (10000 more
    with ``make test-all``)."""

    @settings(max_examples=examples, **SETTINGS)
    @given(layouts())
    def check(d):
        layout = emitted(d)
        if layout is not None:
            try:
                check_dry_runs(layout)
            finally:
                shutil.rmtree(layout.root)

    check()


RECORDER = f"""#!/bin/sh
# records its argv: $0, then each argument, NUL-terminated, one record per call; answers
# --version as shbake {__version__} would
{{ printf '%s\\0' "$0"; for a in "$@"; do printf '%s\\0' "$a"; done; printf '\\1\\0'; }} >> "$0.log"
case "$*" in *--version) echo "shbake, version {__version__}";; esac
"""
SHELL_LOGGER = """#!/bin/sh
# make's SHELL: records each command line it is given, then runs it with /bin/sh
printf '%s\\0' "$2" >> "$0.log"
exec /bin/sh "$@"
"""


@pytest.mark.heavy
@pytest.mark.parametrize("examples", [500, pytest.param(5000, marks=pytest.mark.slow)])
def test_make_runs_exactly_the_expected_commands(examples):
    """A real ``make scene-assets``: one shell per recipe, each running the command with
    exactly the expected argv (the drawn ``--shbake`` words after the recorder's path);
    500 drawn scenes (5000 more with ``make test-all``)."""

    tools = Path(tempfile.mkdtemp(prefix="shbake-tools-"))
    recorder, logger = tools / "record", tools / "sh-log"
    recorder.write_text(RECORDER)
    logger.write_text(SHELL_LOGGER)
    for p in (recorder, logger):
        p.chmod(0o755)
    logs = (tools / "record.log", tools / "sh-log.log")

    @settings(max_examples=examples, **SETTINGS)
    @given(layouts(st.lists(segments(), max_size=2)))
    def check(d):
        for log in logs:
            log.unlink(missing_ok=True)
        d = dict(d, shbake=shlex.join([str(recorder), *shlex.split(d["shbake"])]))
        layout = emitted(d)
        if layout is None:
            return
        try:
            before = sorted(layout.root.rglob("*"))
            done = make(layout, "scene-assets", shell=logger)
            assert done.returncode == 0, done.stderr
            words = shlex.split(layout.shbake)
            shells = logs[1].read_bytes().decode().split("\0")[:-1]
            assert len(version_queries(shells, words)) == len(layout.outputs())
            calls, call = [], []
            for x in logs[0].read_bytes().decode().split("\0")[:-1]:
                if x == "\1":
                    calls.append(call)
                    call = []
                else:
                    call.append(x)
            asked = [*words, "--version"]
            assert asked in calls
            assert sorted(c for c in calls if c != asked) == expected_bake(layout, words)
            assert sorted(layout.root.rglob("*")) == before  # nothing else ran
        finally:
            shutil.rmtree(layout.root)

    try:
        check()
    finally:
        shutil.rmtree(tools)


def test_outside_out_dir_recipes_carry_the_flag(tmp_path):
    """An out_dir outside the scene's folder (allowed by --allow-outside at plan time): the
    fragment's recipes pass --allow-outside on, or every make rule would be refused."""
    d = {"folder": "scene", "scene": "s", "map_folder": "maps", "map": "sky", "out_dir": "x",
         "fragment": "s.mk", "env": None, "name": "s", "materials": ["a", "b"],
         "shbake": "shbake"}  # fmt: skip
    layout = Layout(tmp_path, d)
    layout.out = tmp_path / "elsewhere"
    layout.scene.write_text(layout.scene.read_text().replace('"x"', '"../elsewhere"'))
    scene = load_scene(str(layout.scene), allow_outside=True)
    emit_make(scene, layout.plan(), str(layout.fragment), layout.shbake)
    shell = tmp_path / "sh-record"
    shell.write_text(SHELL_RECORDER)
    shell.chmod(0o755)
    dry = make(layout, "-n", "-W", named(layout.scene, layout.folder), "scene-assets", shell=shell)
    lines = [sh_words(line) for line in dry.stdout.split("\n") if line]
    assert len(lines) == 4 and all(w[-2:] == ["--allow-outside", "--quiet"] for w in lines)


@pytest.mark.parametrize("word", ["else", "endif", "ifeq", "include", "export", "define"])
def test_fragment_named_after_a_make_directive(tmp_path, word):
    """A fragment (and scene) named after a make directive: its self-remake rules start with
    ``./`` and make reads them as rules, not directives (found by the property test: a
    fragment named ``else`` gave "extraneous 'else'. Stop.")."""
    d = {"folder": "scene", "scene": word, "map_folder": "maps", "map": "sky", "out_dir": "x",
         "fragment": word, "env": None, "name": "s", "materials": ["a", "b"],
         "shbake": "shbake"}  # fmt: skip
    layout = Layout(tmp_path, d)
    emit_make(load_scene(str(layout.scene)), layout.plan(), str(layout.fragment), layout.shbake)
    shell = tmp_path / "sh-record"
    shell.write_text(SHELL_RECORDER)
    shell.chmod(0o755)
    dry = make(layout, "-n", "scene-assets", shell=shell)
    assert dry.returncode == 0, dry.stderr
    assert len([line for line in dry.stdout.split("\n") if line]) == 3, dry.stdout
