"""The import rules of docs/ARCHITECTURE.md, checked on the source and on a fresh interpreter."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "shbake"

ALLOWED = {
    # stage: the shbake stages it may import (besides itself and the base modules)
    "sh": set(),
    "texture": set(),
    "envmap": {"sh"},
    "brdf": {"sh", "texture"},
    "reference": {"sh", "envmap", "brdf"},
    "shading": {"sh", "texture", "brdf"},
    "format": {"sh", "texture", "brdf", "envmap"},
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
            "import shbake.preview.render",
            "import shbake.preview.passes, shbake.preview.glossy, shbake.preview.kautz_table",
            "import shbake.evaluation.env_sh, shbake.evaluation.probes",
            "import shbake.shading.env_sh, shbake.shading.shexp, shbake.shading.splitsum",
        ],
    )
    def test_no_baker_module_loaded(self, statement):
        loaded = _loaded_after(statement)
        bakers = sorted(m for m in loaded if m.startswith(("shbake.bakers", "shbake.batch")))
        assert not bakers, bakers
        assert "shbake.brdf.tabulate" not in loaded
