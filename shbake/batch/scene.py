"""Scene files: what a scene's probes and materials are, and how accurate each asset must be.

A scene is a TOML file (read with :mod:`tomllib`); ``docs/SCENES.md`` documents
it and ``configs/example-scene.toml`` is a worked example. :func:`load_scene`
validates it completely before any work and raises :class:`SceneError` with
ONE line naming the file, the line and the key (``scene.toml:12: materials[2].roughness:
…``). :mod:`tomllib` keeps no line numbers, so :func:`key_lines` finds each
key's line in the text itself (tables, arrays of tables, dotted and quoted
keys; keys inside inline tables get the line of the key that holds them).

Schema (every key optional unless marked *required*)::

    [scene]        name (str), out_dir (str, relative to the scene file; default "<stem>-assets"),
                   exports (list of str from EXPORTS)
    [tolerances]   irradiance, tangent_irradiance, brdf_table, glossy_probe, shrm: float in
                   (0, 1) (the error each asset kind must stay within; see TOLERANCES)
    [[environments]]  map (str, required: a path or a glob, relative to the scene file),
                   name (str; default: the map's file stem), position ([x, y, z], recorded
                   in its assets), rotation_deg (float: turns the environment about world
                   up +Y, shbake.envmap.turn), tolerances (table: per-probe overrides)
    [[materials]]  name (str, required), kind (required: one of MATERIAL_KINDS),
                   model (str, brdf-table's model name; anisotropic/measured; glossy: an
                   isotropic model other than ggx gets an SHRM),
                   params (table: model parameters as brdf-table's / shrm's -p take them),
                   merl (str: a MERL .binary file, kind "measured"),
                   roughness ([lo, hi] perceptual, glossy GGX; or one number)
"""

import glob
import math
import os
import re
import tomllib
from dataclasses import dataclass, field

from shbake.brdf import MODELS
from shbake.errors import ParameterError

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

    def tolerances(self, data, key: str) -> dict:
        self.table(data, key, {k: (int, float) for k in TOLERANCES})
        for k, v in data.items():
            if not (math.isfinite(v) and 0.0 < v < 1.0):
                self.fail(f"{key}.{k}", f"impossible tolerance {v!r}: must be in (0, 1) "
                          f"({TOLERANCES[k]})")  # fmt: skip
        return dict(data)


MAX_SCENE_BYTES = 16 << 20
"""Largest scene file read (a scene is a few kilobytes of TOML)."""


def load_scene(path: str) -> Scene:
    """Read and validate the scene at ``path``; raises :class:`SceneError` (one line)."""
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
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
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
    stem = os.path.splitext(os.path.basename(path))[0]
    out_dir = os.path.normpath(os.path.join(base, scene.get("out_dir", f"{stem}-assets")))
    tolerances = dict(DEFAULT_TOLERANCES)
    tolerances.update(chk.tolerances(data.get("tolerances", {}), "tolerances"))

    envs = data.get("environments", [])
    if not envs:
        chk.fail("environments", "a scene needs at least one [[environments]] entry")
    environments = []
    for i, env in enumerate(envs):
        key = f"environments[{i}]"
        chk.table(env, key, ENV_KEYS)
        if "map" not in env:
            chk.fail(key, "missing required key 'map'")
        pattern = os.path.join(base, env["map"])
        found = sorted(glob.glob(pattern)) if glob.has_magic(pattern) else [pattern]
        found = [p for p in found if os.path.isfile(p)]
        if not found:
            chk.fail(f"{key}.map", f"no such map: {env['map']} (relative to {base})")
        pos = env.get("position", [0.0, 0.0, 0.0])
        if len(pos) != 3 or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                    and math.isfinite(x) for x in pos):  # fmt: skip
            chk.fail(f"{key}.position", f"must be three finite numbers, got {pos!r}")
        tol = chk.tolerances(env.get("tolerances", {}), f"{key}.tolerances")
        for m in found:
            name = env.get("name") if len(found) == 1 and "name" in env else None
            name = name or os.path.splitext(os.path.basename(m))[0]
            if not re.fullmatch(r"[A-Za-z0-9_.-]+", name):
                chk.fail(f"{key}.name", f"{name!r}: names use letters, digits, '_', '-', '.'")
            if any(e.name == name for e in environments):
                chk.fail(f"{key}.name", f"duplicate environment name {name!r}")
            environments.append(Environment(name, os.path.abspath(m), tuple(map(float, pos)),
                                            float(env.get("rotation_deg", 0.0)), tol,
                                            key))  # fmt: skip

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
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", mat["name"]):
            chk.fail(f"{key}.name", f"{mat['name']!r}: names use letters, digits, '_', '-', '.'")
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
            if not os.path.isfile(merl):
                chk.fail(f"{key}.merl", f"no such file: {mat['merl']}")
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
                from shbake.bakers.shrm import make_reflection_brdf

                make_reflection_brdf("ggx", {"alpha": "0.5", **_param_strings(params)})
            except ParameterError as e:
                chk.fail(f"{key}.params", str(e))
        if model is not None and kind != "glossy":
            try:  # brdf-table's own validation of the parameters
                from shbake.brdf import make_brdf

                make_brdf(model, merl_path=merl, **_param_strings(params))
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
                 lines)  # fmt: skip


def _check_reflection_model(chk: _Checker, key: str, mat: dict) -> None:
    """A glossy material with a model other than GGX gets an SHRM: the model must be one the
    SHRM takes (isotropic; :func:`shbake.bakers.shrm.make_reflection_brdf` says)."""
    from shbake.bakers.shrm import LOBE_MODELS, TANGENT_MODELS, make_reflection_brdf

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
        make_reflection_brdf(model, _param_strings(mat.get("params", {})))
    except ParameterError as e:
        chk.fail(f"{key}.params", str(e))


def _param_strings(params: dict) -> dict:
    """Scene parameter values as brdf-table's ``-p NAME=VALUE`` strings (arrays → ``r,g,b``)."""
    return {k: ",".join(map(str, v)) if isinstance(v, list) else str(v) for k, v in params.items()}
