"""The code's shape: no function under svhdesc/ longer than MAX_LINES (from its `def` line to its last line), and
ruff's mccabe complexity bound in the project's config (ruff itself enforces it)."""

from __future__ import annotations

import ast
import sys

import pytest

from tests.support import REPO

MAX_LINES = 60
MAX_COMPLEXITY = 12


def long_functions(source: str, name: str) -> list[str]:
    """'file:line function (n lines)' for each function or method in `source` longer than MAX_LINES."""
    found = []
    for node in ast.walk(ast.parse(source, name)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            length = node.end_lineno - node.lineno + 1
            if length > MAX_LINES:
                found.append(f"{name}:{node.lineno} {node.name} ({length} lines)")
    return found


def _function(name: str, body_lines: int, indent: str = "") -> str:
    """A function of 1 + body_lines lines."""
    body = "".join(f"{indent}    x{i} = {i}\n" for i in range(body_lines))
    return f"{indent}def {name}() -> None:\n{body}"


def test_no_function_is_longer_than_the_bound() -> None:
    found = []
    for path in sorted((REPO / "svhdesc").rglob("*.py")):
        found += long_functions(path.read_text(encoding="utf-8"), str(path.relative_to(REPO)))
    assert not found, f"functions over {MAX_LINES} lines: " + "; ".join(found)


def test_seeded_long_function_is_caught_at_one_line_over() -> None:
    # The bound counts from `def` to the last line: 60 lines pass, 61 fail, nested and in classes alike.
    assert long_functions(_function("fits", MAX_LINES - 1), "fits.py") == []
    assert long_functions(_function("too_long", MAX_LINES), "long.py") == ["long.py:1 too_long (61 lines)"]
    method = "class Holder:\n" + _function("method", MAX_LINES, indent="    ")
    assert long_functions(method, "method.py") == ["method.py:2 method (61 lines)"]
    nested = "def outer() -> None:\n" + _function("inner", MAX_LINES, indent="    ")
    assert [f.split()[1] for f in long_functions(nested, "nested.py")] == ["outer", "inner"]


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib is Python 3.11's")
def test_ruff_config_bounds_the_complexity() -> None:
    import tomllib

    lint = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["ruff"]["lint"]
    assert "C90" in lint["select"] or "C901" in lint["select"]
    assert lint["mccabe"]["max-complexity"] == MAX_COMPLEXITY
