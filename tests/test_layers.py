"""The package's layers: imports only go down, the public API is re-exported, and the code is ruff-clean."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import adverbs

SRC = Path(adverbs.__file__).resolve().parent
ROOT = SRC.parent.parent
# Bottom to top. `graph` and `runtime` are the layers to come (verb graphs, the run-time loop).
LAYERS = ["errors", "limits", "compiled", "_scratch_kernel", "interp", "kinematics", "motion", "io", "verb", "feet", "graph", "runtime", "dataset", "apps"]
FACADE = {"adverbs", "adverbs.__main__"}  # the package's front door re-exports from every layer


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _layer(module: str) -> int:
    parts = module.split(".")
    if parts[0] != "adverbs" or len(parts) < 2:
        raise LookupError(module)
    if parts[1] not in LAYERS:
        raise LookupError(f"{module}: subpackage {parts[1]!r} has no layer; add it to LAYERS in {__file__}")
    return LAYERS.index(parts[1])


def upward_imports(module: str, source: str, is_package: bool) -> list[str]:
    """``"module -> target"`` for every import of ``module`` (its source text) that reaches a higher layer."""
    here = _layer(module)
    package = module.split(".") if is_package else module.split(".")[:-1]
    bad = []
    for node in ast.walk(ast.parse(source)):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            # `from . import x` names submodules: each is its own target.
            targets = [f"{target}.{a.name}" for a in node.names] if not node.module else [target]
        for t in targets:
            if t.split(".")[0] != "adverbs" or t == "adverbs":
                continue
            try:
                layer = _layer(t)
            except LookupError:
                continue
            if layer > here:
                bad.append(f"{module} -> {t}")
    return bad


def _modules() -> list[Path]:
    return sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts)


def test_every_module_sits_in_a_layer():
    for path in _modules():
        name = _module_name(path)
        if name not in FACADE:
            _layer(name)  # raises with the fix when a subpackage is missing from LAYERS


def test_imports_only_go_down():
    bad = []
    for path in _modules():
        name = _module_name(path)
        if name in FACADE:
            continue
        bad += upward_imports(name, path.read_text(encoding="utf-8"), path.name == "__init__.py")
    assert not bad, "imports that reach up a layer:\n" + "\n".join(bad)


@pytest.mark.parametrize(
    ("module", "source", "upward"),
    [
        ("adverbs.verb.sampling", "from ..apps.cli import main", True),
        ("adverbs.interp.rbf", "from ..kinematics import quat", True),
        ("adverbs.motion.clip", "import adverbs.verb.tables", True),
        ("adverbs.verb.sampling", "def f():\n    from ..apps import evaluate", True),
        ("adverbs.verb", "from . import sampling", False),
        ("adverbs.verb.sampling", "from ..interp import bspline\nfrom .tables import Verb", False),
        ("adverbs.apps.cli", "from ..verb.fit import build_from_spec", False),
    ],
)
def test_the_checker_sees_upward_imports(module, source, upward):
    assert bool(upward_imports(module, source, module.count(".") == 1)) == upward


def test_the_public_api_is_reexported():
    for name in adverbs.__all__:
        assert hasattr(adverbs, name), name
    for name in ("Verb", "SamplingState", "sample", "build_from_spec", "load_verb", "read_bvh", "plant_feet", "Clip"):
        assert name in adverbs.__all__


def test_ruff_is_clean():
    r = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "src", "tests", "benchmarks"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert r.returncode == 0, r.stdout + r.stderr
