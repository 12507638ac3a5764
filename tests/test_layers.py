"""The house's layers import only downward (docs/guide/layout.md): rl knows nothing of
imitation or the simulators, imitation and the simulators nothing of each other, the
demonstrations nothing of the harness, the harness nothing of analysis, and the algorithms
and analysis nothing of each other or of the command line."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RANK = {
    "bench.errors": -1,  # the one exception every module may derive from
    "bench.validate": 0,
    "bench.atomic": 0,
    "bench.reading": 0,
    "bench.fields": 0,
    "bench.paths": 0,
    "bench.kernels": 0,
    "bench.rl": 1,
    "bench.imitation": 2,
    "bench.envs": 2,
    "bench.demos": 3,
    "bench.harness": 4,
    "bench.analysis": 5,
    "algorithms": 5,
    "bench.cli": 6,
}
"""Each layer may import those of a lower rank, and its own."""


def layer_of(module: str) -> str | None:
    for layer in sorted(RANK, key=len, reverse=True):
        if module == layer or module.startswith(layer + "."):
            return layer
    return None


def imports(path: Path) -> set[str]:
    """The modules `path` imports, at any depth (lazy imports in functions count too)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def modules() -> list[Path]:
    return sorted([*(ROOT / "bench").rglob("*.py"), *(ROOT / "algorithms").rglob("*.py")])


def test_every_module_is_in_a_layer():
    for path in modules():
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        if name.endswith("__init__") and name.count(".") <= 1:
            continue  # the packages themselves
        assert layer_of(name), f"{name} is in no layer"


@pytest.mark.parametrize("path", modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_only_go_down(path):
    name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    mine = layer_of(name)
    if mine is None:
        return
    for imported in imports(path):
        theirs = layer_of(imported)
        if theirs is None or theirs == mine:
            continue
        assert RANK[theirs] < RANK[mine], f"{name} ({mine}) imports {imported} ({theirs})"
