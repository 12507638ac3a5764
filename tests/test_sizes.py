"""The house stays small enough to read: no function over MAX_FUNCTION lines and no module over
MAX_MODULE lines in bench/ and algorithms/ (a function that grows past it has more than one
job; a module, more than one subject)."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_FUNCTION = 80
MAX_MODULE = 450
MODULES = sorted([*(ROOT / "bench").rglob("*.py"), *(ROOT / "algorithms").rglob("*.py")])


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_and_functions_are_short(path):
    source = path.read_text()
    assert source.count("\n") <= MAX_MODULE, f"{path.name}: over {MAX_MODULE} lines"
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            length = node.end_lineno - node.lineno + 1
            assert length <= MAX_FUNCTION, f"{node.name} (line {node.lineno}): {length} lines"
