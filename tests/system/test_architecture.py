"""The import rules of docs/ARCHITECTURE.md, checked on the source and on a fresh interpreter:
stages import only the stages below them, no two modules import each other (directly or in
a circle, function-local imports included), no ``_private`` name is used outside its
module, and the preview and the evaluation reach shaders only through the registry."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "shbake"

ALLOWED = {
    # stage: the shbake stages it may import (besides itself and the base modules)
    "sh": set(),
    "texture": set(),
    "envmap": {"sh"},
    "brdf": {"sh", "texture"},
    "reference": {"sh", "texture", "envmap", "brdf"},
    "shading": {"sh", "texture", "brdf", "format"},
    "format": {"sh", "texture", "brdf", "envmap"},
    "shaders": set(),  # GLSL and the viewer: package data, no Python
    "bakers": {"sh", "texture", "envmap", "brdf", "format", "reference", "shading"},
    "preview": {"sh", "texture", "envmap", "brdf", "format", "shading", "reference"},
    "evaluation": {"sh", "texture", "envmap", "brdf", "format", "shading", "reference", "preview"},
    "batch": {
        "sh",
        "texture",
        "envmap",
        "brdf",
        "format",
        "shading",
        "reference",
        "preview",
        "evaluation",
        "bakers",
    },  # fmt: skip
}
BASE = {"conventions", "errors", "jit", "messages", "progress", "resources", "signals", "simd"}
"""Modules of the package root every stage may import."""


def imports_of(path: Path):
    """``(module, names)`` of every ``import``/``from … import`` of shbake in a file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("shbake"):
            yield node.module, [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("shbake"):
                    yield a.name, []


def stage_files():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).parts
        if len(rel) > 1:
            yield rel[0], path


class TestImportRules:
    @pytest.mark.parametrize("stage", sorted(ALLOWED))
    def test_stage_imports_only_what_it_may(self, stage):
        bad = []
        for owner, path in stage_files():
            if owner != stage:
                continue
            for module, _ in imports_of(path):
                parts = module.split(".")
                if len(parts) < 2 or parts[1] in BASE or parts[1] == stage:
                    continue
                if parts[1] not in ALLOWED[stage]:
                    bad.append(f"{path.relative_to(PACKAGE)} imports {module}")
        assert not bad, "\n".join(bad)

    def test_every_stage_is_declared(self):
        stages = {owner for owner, _ in stage_files()}
        assert stages <= set(ALLOWED), stages - set(ALLOWED)

    def test_no_private_name_crosses_a_package(self):
        bad = []
        for owner, path in stage_files():
            for module, names in imports_of(path):
                parts = module.split(".")
                other = len(parts) > 1 and parts[1] != owner
                private = [n for n in names if n.startswith("_")]
                if other and (private or any(p.startswith("_") for p in parts)):
                    bad.append(f"{path.relative_to(PACKAGE)}: {module} {private}")
        assert not bad, "\n".join(bad)


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}
"""Every module of the package by dotted name."""


def import_graph() -> dict[str, set[str]]:
    """Module → the shbake modules it imports anywhere in its body (``from pkg import mod``
    counts as importing ``pkg.mod``)."""
    graph = {}
    for name, path in MODULES.items():
        edges = set()
        for module, names in imports_of(path):
            targets = [f"{module}.{n}" for n in names if f"{module}.{n}" in MODULES]
            edges.update(targets or ([module] if module in MODULES else []))
        edges.discard(name)
        graph[name] = edges
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


class TestModuleGraph:
    def test_no_circles_between_modules(self):
        found = circles(import_graph())
        assert not found, found

    def test_circle_finder_finds_one(self):
        assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]

    def test_no_private_name_used_outside_its_module(self):
        bad = []
        for name, path in MODULES.items():
            tree = ast.parse(path.read_text(encoding="utf-8"))
            aliases = set()  # names bound to shbake modules in this file
            for module, names in imports_of(path):
                if any(p.startswith("_") and p != "__init__" for p in module.split(".")):
                    bad.append(f"{name}: imports {module}")
                if module != name:
                    bad += [f"{name}: {module}.{n}" for n in names
                            if n.startswith("_") and not n.startswith("__")]  # fmt: skip
                aliases.update(n for n in names if f"{module}.{n}" in MODULES)
            for node in ast.walk(tree):
                if isinstance(node, ast.Import):
                    aliases.update(a.asname for a in node.names if a.asname)
                if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                        and node.value.id in aliases and node.attr.startswith("_")
                        and not node.attr.startswith("__")):  # fmt: skip
                    bad.append(f"{name}: {node.value.id}.{node.attr}")
        assert not bad, "\n".join(bad)

    @pytest.mark.parametrize("place", ["preview", "evaluation", "batch.preview",
                                       "batch.probe_eval", "batch.scene_bake"])  # fmt: skip
    def test_shaders_only_through_the_registry(self, place):
        """The preview, the evaluation, probe-eval and the scene bake's error checks name no
        shading module but the registry (:mod:`shbake.shading.shader`)."""
        bad = []
        for name, path in MODULES.items():
            if not (name == f"shbake.{place}" or name.startswith(f"shbake.{place}.")):
                continue
            for module, names in imports_of(path):
                targets = [f"{module}.{n}" for n in names] + [module]
                for t in targets:
                    if (
                        t.startswith("shbake.shading.")
                        and t in MODULES
                        and t != ("shbake.shading.shader")
                    ):
                        bad.append(f"{name} imports {t}")
                if module.startswith("shbake.shading.") and module != "shbake.shading.shader":
                    bad.append(f"{name} imports {module}")
        assert not bad, "\n".join(sorted(set(bad)))


CLI = PACKAGE.parent / "cli"


def literal_choices(path: Path) -> list[str]:
    """``click.Choice`` calls in ``path`` whose choices are written out as a literal list or
    tuple of strings (rather than a library constant, or an expression built from one)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and node.func.attr == "Choice" and node.args):  # fmt: skip
            continue
        arg = node.args[0]
        if isinstance(arg, ast.List | ast.Tuple) and all(
            isinstance(e, ast.Constant) and isinstance(e.value, str) for e in arg.elts
        ):
            found.append(f"{path.name}:{node.lineno}")
    return found


class TestCliChoices:
    def test_choices_come_from_library_constants(self):
        """A command's choices are the library's own tuple (the one its validation reads),
        never a copy that can drift from it (issue 28 item 7)."""
        bad = [hit for path in sorted(CLI.glob("*.py")) for hit in literal_choices(path)]
        assert not bad, bad

    def test_finder_finds_a_literal(self, tmp_path):
        (tmp_path / "m.py").write_text('import click\nclick.Choice(["a", "b"])\n'
                                       "click.Choice(NAMES)\n")  # fmt: skip
        assert literal_choices(tmp_path / "m.py") == ["m.py:2"]


def _loaded_after(statement: str) -> set[str]:
    code = (
        "import sys\n" + statement + "\n"
        "print(' '.join(m for m in sys.modules if m.startswith('shbake.')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


class TestDownstreamLoadsNoBaker:
    @pytest.mark.parametrize(
        "statement",
        [
            "import shbake.preview.passes, shbake.preview.overview",
            "import shbake.preview.passes",
            "import shbake.evaluation.env_sh, shbake.evaluation.probes",
            "import shbake.shading.env_sh, shbake.shading.shexp, shbake.shading.splitsum",
        ],
    )
    def test_no_baker_module_loaded(self, statement):
        loaded = _loaded_after(statement)
        bakers = sorted(m for m in loaded if m.startswith(("shbake.bakers", "shbake.batch")))
        assert not bakers, bakers
        assert "shbake.brdf.tabulate" not in loaded


def imported_modules(path: Path) -> list[str]:
    """Every module a test or benchmark file imports (function-local imports included)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append(node.module)
        elif isinstance(node, ast.Import):
            found += [a.name for a in node.names]
    return found


class TestTestImports:
    """Tests and benchmarks share code through helper modules (``tests/helpers.py``,
    ``tests/faults.py``, ``tests/references.py``, …), imported one way (``tests.X``), so plain
    ``pytest`` and ``python -m pytest`` collect the same set; no file imports a test module."""

    FILES = sorted((PACKAGE.parent / "tests").rglob("*.py")) + sorted(
        (PACKAGE.parent / "bench").glob("*.py")
    )
    LOCAL = {p.stem for p in (PACKAGE.parent / "tests").rglob("*.py")}

    def test_no_file_imports_a_test_module(self):
        bad = [
            f"{path.name}: {m}"
            for path in self.FILES
            for m in imported_modules(path)
            if m.split(".")[-1].startswith("test_") and m.split(".")[-1] in self.LOCAL
        ]
        assert bad == [], bad

    def test_helpers_are_imported_as_tests_dot(self):
        bad = [
            f"{path.name}: {m}"
            for path in self.FILES
            for m in imported_modules(path)
            if m.split(".")[0] in self.LOCAL
        ]
        assert bad == [], bad

    def test_finder_finds_a_test_module_import(self, tmp_path):
        path = tmp_path / "x.py"
        path.write_text("def f():\n    from tests.test_faults import snapshot\n")
        assert imported_modules(path) == ["tests.test_faults"]


TESTS = PACKAGE.parent / "tests"
CROSS_CUTTING = {
    "cli": "one file per command module of cli/ (test_<command>.py mirrors cli/<command>.py)",
    "system": "properties of the whole tool: faults, full disk, teardown, hostile assets, "
    "golden files, README, architecture, start-up, engine and WebGL rendering",
    "accuracy": "reported error figures against independent measurements (headline errors, "
    "the shared maps, the probe evaluation)",
}
"""Test folders that do not mirror a package of shbake/, and what each holds
(docs/ARCHITECTURE.md, "Tests")."""


def all_test_files() -> list[Path]:
    """Every ``test_*.py`` under tests/ (the node packages under tests/engines excluded)."""
    return sorted(
        p for p in TESTS.rglob("test_*.py") if "engines" not in p.relative_to(TESTS).parts
    )


def mirrored_module(test: Path) -> str | None:
    """What ``tests/<folder>/test_<name>.py`` names: ``shbake/<folder>/<m>.py`` (or the package
    ``<m>/``) where ``<name>`` is ``<m>`` or ``<m>_<aspect>``; ``tests/core/`` names the modules
    of the package root, ``tests/cli/`` those of cli/. None when nothing matches."""
    rel = test.relative_to(TESTS)
    folder = {"core": PACKAGE, "cli": CLI}.get(rel.parts[0], PACKAGE.joinpath(*rel.parts[:-1]))
    name = rel.stem.removeprefix("test_")
    words = name.split("_")
    for n in range(len(words), 0, -1):
        module = "_".join(words[:n])
        for candidate in (folder / f"{module}.py", folder / module / "__init__.py"):
            if candidate.is_file():
                return str(candidate.relative_to(PACKAGE.parent))
    return None


def path_dependent_lines(path: Path) -> list[str]:
    """``"LINE what"`` for each relative import and each use of ``sys.path`` in a file."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level > 0:
            found.append(f"{node.lineno} relative import")
        if isinstance(node, ast.Attribute) and ast.unparse(node) == "sys.path":
            found.append(f"{node.lineno} sys.path")
    return sorted(found, key=lambda line: int(line.split()[0]))


class TestTestLayout:
    """Tests mirror the package (``tests/<package>/test_<module>.py``, docs/ARCHITECTURE.md):
    a reader finds a module's tests by its path, and a test file by the module it tests."""

    def test_no_flat_test_file(self):
        assert sorted(p.name for p in TESTS.glob("test_*.py")) == []

    def test_every_test_file_names_its_module(self):
        bad = [
            str(p.relative_to(TESTS))
            for p in all_test_files()
            if p.relative_to(TESTS).parts[0] not in set(CROSS_CUTTING) - {"cli"}
            and mirrored_module(p) is None
        ]
        assert bad == [], bad

    def test_mirror_finder(self):
        assert mirrored_module(TESTS / "sh" / "test_basis_evaluate.py") == "shbake/sh/basis.py"
        assert mirrored_module(TESTS / "format" / "test_exports.py") == (
            "shbake/format/exports/__init__.py"
        )
        assert mirrored_module(TESTS / "core" / "test_jit.py") == "shbake/jit.py"
        assert mirrored_module(TESTS / "cli" / "test_split_sum.py") == "cli/split_sum.py"
        assert mirrored_module(TESTS / "sh" / "test_nothing.py") is None

    def test_every_test_folder_is_a_package(self):
        """Basenames repeat across folders (``tests/sh/test_basis.py``, ``tests/cli/…``):
        each folder is a package, so its modules import as ``tests.<folder>.<module>`` the
        same way under ``pytest`` and ``python -m pytest`` (rootdir-based "prepend" import)."""
        folders = {p.parent for p in all_test_files()} | {TESTS}
        bad = [str(f.relative_to(PACKAGE.parent)) for f in sorted(folders)
               if not (f / "__init__.py").is_file()]  # fmt: skip
        assert bad == [], bad

    def test_collection_does_not_depend_on_the_working_directory(self):
        """``python -m pytest`` puts the current folder on ``sys.path``, plain ``pytest`` does
        not: no test file or helper may lean on either (no relative import, no ``sys.path``
        edit), so both collect the same set (checked statically: collecting twice costs 20 s)."""
        bad = [
            f"{path.relative_to(TESTS)}:{line}"
            for path in sorted(TESTS.rglob("*.py"))
            if "engines" not in path.relative_to(TESTS).parts
            for line in path_dependent_lines(path)
        ]
        assert bad == [], bad

    def test_finder_finds_a_relative_import_and_sys_path(self, tmp_path):
        path = tmp_path / "t.py"
        path.write_text("import sys\nfrom . import helpers\nsys.path.insert(0, 'x')\n")
        assert path_dependent_lines(path) == ["2 relative import", "3 sys.path"]
