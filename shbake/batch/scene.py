"""Scene files: what a scene's probes and materials are, and how accurate each asset must be.

A scene is a TOML file (read with :mod:`tomllib`); ``docs/SCENES.md`` documents
it and ``configs/example-scene.toml`` is a worked example. :func:`load_scene`
validates it completely before any work and raises :class:`SceneError` with
ONE line naming the file, the line and the key (``scene.toml:12: materials[2].roughness:
…``). :mod:`tomllib` keeps no line numbers, so :func:`key_lines` finds each
key's line in the text itself (tables, arrays of tables, dotted and quoted
keys; keys inside inline tables get the line of the key that holds them).

Schema (every key optional unless marked *required*)::

    [scene]        name (str), out_dir (str, relative to the scene file and inside its folder
                   unless ``allow_outside``; default "<stem>-assets"), exports (distinct
                   str from EXPORTS)
    [tolerances]   irradiance, tangent_irradiance, brdf_table, glossy_probe, shrm: float in
                   (0, 1) (the error each asset kind must stay within; see TOLERANCES)
    [[environments]]  map (str, required: a path or a glob, relative to the scene file),
                   name (NAME_PATTERN; default: the map's file stem), position ([x, y, z],
                   recorded in its assets), rotation_deg (float in [-360, 360]: turns the
                   environment about world up +Y, shbake.envmap.turn), tolerances (table:
                   per-probe overrides)
    [[materials]]  name (NAME_PATTERN, required), kind (required: one of MATERIAL_KINDS),
                   model (str, brdf-table's model name; anisotropic/measured; glossy: an
                   isotropic model other than ggx gets an SHRM),
                   params (table: model parameters as brdf-table's / shrm's -p take them),
                   merl (str: a MERL .binary file, kind "measured"),
                   roughness ([lo, hi] perceptual, glossy GGX; or one number)

Maps a glob matches inside the folders of ``out_dir`` that shbake writes
(:func:`written_by_shbake`) are left out; a map or MERL file named there is refused.
Arrays and inline tables nest at most :data:`MAX_NESTING` deep (checked on the text
before :mod:`tomllib`, which recurses per level).
"""

import glob
import json
import math
import os
import re
import tomllib
from dataclasses import dataclass, field

from shbake.brdf import MODELS
from shbake.errors import ParameterError
from shbake.resources import path_arguments

TOLERANCES = {
    "irradiance": "relative RMS error of Lambert irradiance luminance vs brute force",
    "tangent_irradiance": "relative RMS error of Kajiya-Kay tangent irradiance vs brute force",
    "brdf_table": "relative L2 error of f*(s, v) = f cos: lmax truncation plus bilinear look-up",
    "glossy_probe": "RMS log error of the SH-exp fit against its E0 targets (in-sample)",
    "shrm": "fraction of the BRDF energy the SHRM's orders F, P leave out (RH02 5.1, shrm --eps)",
}
DEFAULT_TOLERANCES = {
    "irradiance": 0.05,
    "tangent_irradiance": 0.05,
    "brdf_table": 0.1,
    "glossy_probe": 0.2,
    "shrm": 0.03,
}
MATERIAL_KINDS = ("diffuse", "fibre", "anisotropic", "measured", "glossy")
EXPORTS = ("babylon", "filament", "gltf", "ktx2", "threejs", "unity")
"""Engine exports a scene may ask for: ``shbake export --to TARGET`` of each map's ``env_sh``
asset (docs/EXPORTS.md); cube targets also prefilter the map."""

NAME_PATTERN = r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}"
"""Environment and material names: 1-64 letters, digits, ``_ . -``, the first not ``.`` or
``-`` (so never ``.``, ``..``, a path or an option). They become file names and asset ids."""
MAX_ROTATION_DEG = 360.0
"""Largest ``|rotation_deg|`` (one full turn)."""
MAX_NESTING = 16
"""Deepest nesting of arrays and inline tables in a scene file (a scene needs 3)."""
LOCK_NAME = "scene.lock.json"
STAMP_DIR = ".stamps"
ASSET_FOLDERS = ("brdf_table", "env_sh", "export", "shexp", "shrm", "splitsum")
"""The folders of ``out_dir`` that hold assets, one per asset kind (``kind/…`` ids)."""

SCENE_KEYS = {"name": str, "out_dir": str, "exports": list}
ENV_KEYS = {"map": str, "name": str, "position": list, "rotation_deg": (int, float),
            "tolerances": dict}  # fmt: skip
MATERIAL_KEYS = {"name": str, "kind": str, "model": str, "params": dict, "merl": str,
                 "roughness": (list, int, float)}  # fmt: skip
TOP_KEYS = {"scene": dict, "tolerances": dict, "environments": list, "materials": list}


class SceneError(ParameterError):
    """A malformed scene: the message is ``FILE:LINE: KEY: what is wrong`` (one line)."""


@dataclass(frozen=True)
class Environment:
    """One probe: its map (absolute path), name, position and rotation, tolerances."""

    name: str
    map: str
    position: tuple[float, float, float]
    rotation_deg: float
    tolerances: dict
    key: str = ""


@dataclass(frozen=True)
class Material:
    """One material: ``kind`` decides its assets; ``key`` is its path in the scene file."""

    name: str
    kind: str
    key: str
    model: str | None = None
    params: dict = field(default_factory=dict)
    merl: str | None = None
    roughness: tuple[float, float] | None = None


@dataclass(frozen=True)
class Scene:
    """A validated scene; ``lines`` maps every key path to its line for later errors."""

    path: str
    name: str
    out_dir: str
    exports: tuple[str, ...]
    tolerances: dict
    environments: tuple[Environment, ...]
    materials: tuple[Material, ...]
    lines: dict
    written_absolute: frozenset[str] = frozenset()
    """The paths the scene file wrote absolute (maps, MERL files, ``out_dir``): its state
    files keep them so, every other path relative (:mod:`shbake.batch.scene_paths`)."""

    def error(self, key: str, message: str) -> SceneError:
        """A :class:`SceneError` for ``key`` (e.g. ``tolerances.irradiance``)."""
        return SceneError(f"{self.path}:{_line_of(self.lines, key)}: {key}: {message}")

    def tolerance(self, kind: str, env: Environment | None = None) -> tuple[float, str]:
        """``(value, key)`` of the tolerance for asset ``kind``, the probe's override first."""
        if env is not None and kind in env.tolerances:
            return env.tolerances[kind], f"{env.key}.tolerances.{kind}"
        return self.tolerances[kind], f"tolerances.{kind}"


_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
_KEY = re.compile(r"^\s*((?:[A-Za-z0-9_-]+|\"[^\"]*\"|'[^']*')(?:\s*\.\s*(?:[A-Za-z0-9_-]+|\"[^\"]*\"|'[^']*'))*)\s*=")  # noqa: E501


def _split_key(text: str) -> list[str]:
    parts = re.findall(r"\"[^\"]*\"|'[^']*'|[A-Za-z0-9_-]+", text)
    return [p[1:-1] if p[0] in "\"'" else p for p in parts]


def key_lines(text: str) -> dict[str, int]:
    """1-based line of every table and key: ``{"materials[1].roughness": 23, …}``.

    Array-of-tables elements are indexed from 0 in the order they appear.
    Multi-line strings and arrays are skipped over by tracking brackets and
    triple quotes (good enough for scene files; a key not found gets line 1).
    """
    lines: dict[str, int] = {}
    counts: dict[str, int] = {}
    prefix = ""
    depth = 0
    in_triple = None
    for number, raw in enumerate(text.splitlines(), 1):
        if in_triple:
            if in_triple in raw:
                in_triple = None
            continue
        if depth > 0:
            depth += raw.count("[") - raw.count("]")
            continue
        header = _HEADER.match(raw)
        if header and not _KEY.match(raw):
            parts = _split_key(header.group(2))
            base = ".".join(parts)
            if header.group(1) == "[[":
                index = counts.get(base, -1) + 1
                counts[base] = index
                prefix = f"{base}[{index}]"
            else:
                # [a.b] inside the latest element of an array a
                head, rest = parts[0], parts[1:]
                prefix = f"{head}[{counts[head]}]" if head in counts else head
                if rest:
                    prefix += "." + ".".join(rest)
            lines.setdefault(prefix, number)
            continue
        key = _KEY.match(raw)
        if key:
            name = ".".join(_split_key(key.group(1)))
            full = f"{prefix}.{name}" if prefix else name
            lines.setdefault(full, number)
            value = raw[key.end():]
            for q in ('"""', "'''"):
                if value.count(q) == 1:
                    in_triple = q
            stripped = re.sub(r"\"[^\"]*\"|'[^']*'", "", value.split("#")[0])
            depth = stripped.count("[") - stripped.count("]")
    return lines


def _line_of(lines: dict, key: str) -> int:
    """The line of ``key`` or of its nearest enclosing key."""
    k = key
    while k:
        if k in lines:
            return lines[k]
        k = re.sub(r"(\.[^.\[]*|\[\d+\])$", "", k) if re.search(r"[.\[]", k) else ""
    return 1


def _finite(x) -> bool:
    """Whether the TOML number ``x`` is a finite float (a 400-digit integer is not)."""
    try:
        return math.isfinite(x)
    except OverflowError:
        return False


def _type_name(t) -> str:
    names = {str: "a string", list: "an array", dict: "a table", int: "an integer",
             float: "a number"}  # fmt: skip
    ts = t if isinstance(t, tuple) else (t,)
    return " or ".join(names.get(x, x.__name__) for x in ts)


class _Checker:
    def __init__(self, path: str, lines: dict):
        self.path, self.lines = path, lines

    def fail(self, key: str, message: str):
        raise SceneError(f"{self.path}:{_line_of(self.lines, key)}: {key}: {message}")

    def table(self, data, key: str, allowed: dict) -> dict:
        if not isinstance(data, dict):
            self.fail(key, f"must be a table, got {type(data).__name__}")
        for k, v in data.items():
            full = f"{key}.{k}" if key else k
            if k not in allowed:
                self.fail(full, f"unknown key (allowed: {', '.join(allowed)})")
            t = allowed[k]
            ts = t if isinstance(t, tuple) else (t,)
            if isinstance(v, bool) or not isinstance(v, ts):
                self.fail(full, f"must be {_type_name(t)}, got {type(v).__name__} {v!r}")
        return data

    def name(self, key: str, name: str) -> str:
        """``name`` if it matches :data:`NAME_PATTERN`."""
        if not re.fullmatch(NAME_PATTERN, name):
            self.fail(key, f"{name!r}: a name is 1-64 letters, digits, '_', '-' or '.', "
                      "the first not '.' or '-'")  # fmt: skip
        return name

    def not_written_by_shbake(self, key: str, path: str, out_dir: str) -> None:
        """Refuse an input ``path`` where shbake writes (its outputs would replace it)."""
        top = written_by_shbake(path, out_dir)
        if top is not None:
            self.fail(key, f"{path} is in {os.path.join(out_dir, top)}, which shbake writes "
                      "(scene.out_dir): move it or change out_dir")  # fmt: skip

    def tolerances(self, data, key: str) -> dict:
        self.table(data, key, {k: (int, float) for k in TOLERANCES})
        for k, v in data.items():
            if not (_finite(v) and 0.0 < v < 1.0):
                self.fail(f"{key}.{k}", f"impossible tolerance {v!r}: must be in (0, 1) "
                          f"({TOLERANCES[k]})")  # fmt: skip
        return dict(data)


MAX_SCENE_BYTES = 16 << 20
"""Largest scene file read (a scene is a few kilobytes of TOML)."""

_TOML_TOKEN = re.compile(r'"""(?:[^\\]|\\.)*?"""|\'\'\'.*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\''
                         r"|#[^\n]*|[\[\]{}]", re.S)  # fmt: skip
"""Strings and comments (skipped whole) and the brackets of a TOML text."""


def too_deep(text: str) -> int | None:
    """The line where the arrays and inline tables of TOML ``text`` nest deeper than
    :data:`MAX_NESTING`, or ``None`` (table headers count their brackets too)."""
    depth = 0
    for m in _TOML_TOKEN.finditer(text):
        c = m.group()
        if c in "[{":
            depth += 1
            if depth > MAX_NESTING:
                return text.count("\n", 0, m.start()) + 1
        elif c in "]}":
            depth = max(depth - 1, 0)
    return None


def is_inside(path: str, folder: str) -> bool:
    """Whether ``path`` is ``folder`` or below it, symbolic links resolved."""
    real, root = os.path.realpath(path), os.path.realpath(folder)
    return os.path.commonpath([real, root]) == root


def written_by_shbake(path: str, out_dir: str) -> str | None:
    """The entry of ``out_dir`` that shbake writes and ``path`` is or is inside (an asset
    folder, the settings stamps, the lock), or ``None``."""
    if not is_inside(path, out_dir):
        return None
    rel = os.path.relpath(os.path.realpath(path), os.path.realpath(out_dir))
    top = rel.split(os.sep)[0]
    return top if top in ASSET_FOLDERS + (STAMP_DIR, LOCK_NAME) else None


@path_arguments("path")
def load_scene(path: str, allow_outside: bool = False) -> Scene:
    """Read and validate the scene at ``path``; raises :class:`SceneError` (one line).

    ``allow_outside``: ``out_dir`` may be outside the scene's folder (else refused).
    Every map and MERL file is recorded as an input of the run
    (:func:`shbake.resources.note_input`: no output may replace it).
    """
    from shbake import resources
    from shbake.errors import ShbakeError

    try:  # a FIFO or /dev/zero would block or never end: refused before opening
        raw = resources.read_bounded(path, MAX_SCENE_BYTES, "scene")
    except ShbakeError as e:
        reason = str(e).removeprefix(f"{path}: ")
        raise SceneError(f"{path}:1: (file): {reason}") from None
    except OSError as e:
        raise SceneError(f"{path}:1: (file): cannot read: {e.strerror}") from None
    text = raw.decode("utf-8", errors="replace")
    deep = too_deep(text)
    if deep is not None:
        raise SceneError(f"{path}:{deep}: (syntax): arrays and inline tables nested deeper "
                         f"than {MAX_NESTING} levels")  # fmt: skip
    try:
        data = tomllib.loads(text)
    except ValueError as e:  # TOMLDecodeError, or an integer of more than 4300 digits
        m = re.search(r"line (\d+)", str(e))
        raise SceneError(f"{path}:{m.group(1) if m else 1}: (syntax): {e}") from None
    lines = key_lines(text)
    chk = _Checker(path, lines)
    chk.table(data, "", TOP_KEYS)
    base = os.path.dirname(os.path.abspath(path))

    scene = chk.table(data.get("scene", {}), "scene", SCENE_KEYS)
    exports = scene.get("exports", [])
    for i, e in enumerate(exports):
        if e not in EXPORTS:
            chk.fail(f"scene.exports[{i}]", f"unknown export {e!r} (allowed: {', '.join(EXPORTS)})")
        if e in exports[:i]:
            chk.fail(f"scene.exports[{i}]", f"duplicate export {e!r}")
    stem = os.path.splitext(os.path.basename(path))[0]
    out_dir = os.path.normpath(os.path.join(base, scene.get("out_dir", f"{stem}-assets")))
    written_absolute = {out_dir} if os.path.isabs(scene.get("out_dir", "")) else set()
    if not allow_outside and not is_inside(out_dir, base):
        chk.fail("scene.out_dir", f"{out_dir} is outside the scene's folder {base} (give "
                 "--allow-outside to write there)")  # fmt: skip
    tolerances = dict(DEFAULT_TOLERANCES)
    tolerances.update(chk.tolerances(data.get("tolerances", {}), "tolerances"))

    envs = data.get("environments", [])
    if not envs:
        chk.fail("environments", "a scene needs at least one [[environments]] entry")
    environments = []
    names: set[str] = set()  # the environments' names so far (a glob of 10,000 maps: no scan)
    for i, env in enumerate(envs):
        key = f"environments[{i}]"
        chk.table(env, key, ENV_KEYS)
        if "map" not in env:
            chk.fail(key, "missing required key 'map'")
        if glob.has_magic(env["map"]):  # never shbake's own outputs (the lock, assets, stamps)
            pattern = os.path.join(glob.escape(base), env["map"])
            found = [p for p in sorted(glob.glob(pattern)) if not written_by_shbake(p, out_dir)]
        else:
            found = [os.path.join(base, env["map"])]
            chk.not_written_by_shbake(f"{key}.map", found[0], out_dir)
        found = [p for p in found if os.path.isfile(p)]
        if not found:
            chk.fail(f"{key}.map", f"no such map: {env['map']} (relative to {base})")
        pos = env.get("position", [0.0, 0.0, 0.0])
        if len(pos) != 3 or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                    and _finite(x) for x in pos):  # fmt: skip
            chk.fail(f"{key}.position", f"must be three finite numbers, got {pos!r}")
        turn = env.get("rotation_deg", 0.0)
        if not (_finite(turn) and abs(turn) <= MAX_ROTATION_DEG):
            chk.fail(f"{key}.rotation_deg", f"must be a finite number of degrees in "
                     f"[{-MAX_ROTATION_DEG:g}, {MAX_ROTATION_DEG:g}], got {turn!r}")  # fmt: skip
        tol = chk.tolerances(env.get("tolerances", {}), f"{key}.tolerances")
        if "name" in env and len(found) > 1:  # issue 32: was silently ignored
            chk.fail(f"{key}.name", f"one name for the {len(found)} maps {env['map']!r} "
                     "matches; a glob's probes take their files' names")  # fmt: skip
        for m in found:
            map_stem = os.path.splitext(os.path.basename(m))[0]
            name = chk.name(f"{key}.name", env["name"] if len(found) == 1 and "name" in env
                            else map_stem)  # fmt: skip
            if name in names:
                chk.fail(f"{key}.name", f"duplicate environment name {name!r}")
            names.add(name)
            resources.note_input(m)
            if os.path.isabs(env["map"]):
                written_absolute.add(os.path.abspath(m))
            environments.append(Environment(name, os.path.abspath(m), tuple(map(float, pos)),
                                            float(turn), tol, key))  # fmt: skip

    materials = []
    for i, mat in enumerate(data.get("materials", [])):
        key = f"materials[{i}]"
        chk.table(mat, key, MATERIAL_KEYS)
        for req in ("name", "kind"):
            if req not in mat:
                chk.fail(key, f"missing required key {req!r}")
        kind = mat["kind"]
        if kind not in MATERIAL_KINDS:
            chk.fail(f"{key}.kind", f"unknown kind {kind!r} (allowed: {', '.join(MATERIAL_KINDS)})")
        chk.name(f"{key}.name", mat["name"])
        model = mat.get("model")
        if kind == "glossy" and model not in (None, "ggx"):
            _check_reflection_model(chk, key, mat)
        elif kind == "anisotropic" and model is None:
            chk.fail(key, "an anisotropic material needs 'model' (e.g. ashikhmin-shirley)")
        if model is not None and model not in MODELS:
            chk.fail(f"{key}.model", f"unknown BRDF model {model!r} (allowed: {', '.join(MODELS)})")
        merl = mat.get("merl")
        if kind == "measured":
            if merl is None:
                chk.fail(key, "a measured material needs 'merl' (a MERL .binary file)")
            merl = os.path.join(base, merl)
            chk.not_written_by_shbake(f"{key}.merl", merl, out_dir)
            if not os.path.isfile(merl):
                chk.fail(f"{key}.merl", f"no such file: {mat['merl']}")
            resources.note_input(merl)
            if os.path.isabs(mat["merl"]):
                written_absolute.add(merl)
            model = "merl"
        params = mat.get("params", {})
        for k, v in params.items():
            if isinstance(v, bool) or not isinstance(v, (int, float, str, list)):
                chk.fail(f"{key}.params.{k}", f"must be a number, a string or an array, got {v!r}")
        if kind == "glossy" and model in (None, "ggx") and set(params) - {"F0"}:
            chk.fail(f"{key}.params", "a GGX glossy material takes 'roughness' and at most "
                     "params.F0 (Schlick F0, used by an SHRM; the probes apply F0 at shading)")
        if kind == "glossy" and model in (None, "ggx") and params:
            try:
                from shbake.brdf.reflection import make_reflection_brdf

                make_reflection_brdf("ggx", {"alpha": "0.5", **param_strings(params)})
            except ParameterError as e:
                chk.fail(f"{key}.params", str(e))
        if model is not None and kind != "glossy":
            try:  # brdf-table's own validation of the parameters
                from shbake.brdf import make_brdf

                make_brdf(model, merl_path=merl, **param_strings(params))
            except ParameterError as e:
                chk.fail(f"{key}.params", str(e))
        rough = None
        if kind == "glossy" and model in (None, "ggx"):
            model = "ggx"
            r = mat.get("roughness")
            if r is None:
                chk.fail(key, "a glossy material needs 'roughness' ([lo, hi] or one number)")
            rr = [r, r] if isinstance(r, (int, float)) else r
            if (len(rr) != 2 or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                        for x in rr)
                    or not 0.0 <= rr[0] <= rr[1] <= 1.0):  # fmt: skip
                chk.fail(f"{key}.roughness", f"must be lo <= hi in [0, 1], got {r!r}")
            rough = (float(rr[0]), float(rr[1]))
        if any(m.name == mat["name"] for m in materials):
            chk.fail(f"{key}.name", f"duplicate material name {mat['name']!r}")
        materials.append(Material(mat["name"], kind, key, model, dict(params), merl, rough))
    if not materials:
        chk.fail("materials", "a scene needs at least one [[materials]] entry")
    return Scene(path, scene.get("name", stem), out_dir,
                 tuple(exports), tolerances, tuple(environments), tuple(materials),
                 lines, frozenset(written_absolute))  # fmt: skip


def _check_reflection_model(chk: _Checker, key: str, mat: dict) -> None:
    """A glossy material with a model other than GGX gets an SHRM: the model must be one the
    SHRM takes (isotropic; :func:`shbake.brdf.reflection.make_reflection_brdf` says)."""
    from shbake.brdf.reflection import LOBE_MODELS, TANGENT_MODELS, make_reflection_brdf

    model = mat["model"]
    if "roughness" in mat:
        chk.fail(f"{key}.roughness", f"'roughness' is for GGX; give {model}'s own parameters "
                 "in 'params'")  # fmt: skip
    if "merl" in mat:
        chk.fail(f"{key}.merl", "measured BRDFs are kind \"measured\" (a Kautz table)")
    if model not in MODELS or model in LOBE_MODELS + TANGENT_MODELS + ("merl", "lambert"):
        allowed = [m for m in MODELS if m not in TANGENT_MODELS + ("merl", "lambert")]
        chk.fail(f"{key}.model", f"a glossy material's model must be an isotropic surface "
                 f"BRDF (allowed: {', '.join(allowed)})")  # fmt: skip
    try:
        make_reflection_brdf(model, param_strings(mat.get("params", {})))
    except ParameterError as e:
        chk.fail(f"{key}.params", str(e))


def param_strings(params: dict) -> dict:
    """Scene parameter values as brdf-table's ``-p NAME=VALUE`` strings (arrays → ``r,g,b``)."""
    return {k: ",".join(map(str, v)) if isinstance(v, list) else str(v) for k, v in params.items()}


# ---------------------------------------------------------------------------------------------
# Where a scene's outputs go


def asset_output(out_dir: str, aid: str) -> str:
    """Where asset ``aid`` is written: ``OUT/ID.h5``; an export's listing of its files
    ``OUT/export/TARGET/MAP/files.json``."""
    if aid.startswith("export/"):
        return os.path.join(out_dir, aid, "files.json")
    return os.path.join(out_dir, aid + ".h5")


def lock_path(scene: Scene) -> str:
    return os.path.join(scene.out_dir, LOCK_NAME)


def stamp_path(out_dir: str, aid: str) -> str:
    """The settings stamp of asset ``aid`` (what make depends on): ``OUT/.stamps/ID.json``,
    one folder per part of the id (names hold no ``/``, so no two ids share a stamp)."""
    return os.path.join(out_dir, STAMP_DIR, *aid.split("/")) + ".json"


def settings_value(asset: dict) -> dict:
    """What decides an asset's bytes (kind, settings, inputs' hashes): its stamp's value."""
    return {k: asset[k] for k in ("id", "kind", "output", "inputs", "input_hashes", "settings")}


def settings_text(asset: dict) -> str:
    """An asset's stamp file's text: :func:`settings_value` as indented JSON."""
    return json.dumps(settings_value(asset), sort_keys=True, indent=1) + "\n"
