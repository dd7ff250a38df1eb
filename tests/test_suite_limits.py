"""The test suite's own limits agree: a test's subprocess gives up before pytest-timeout stops
the test, so it fails with its own message (the command and its output)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_every_literal_subprocess_timeout_is_below_the_tests_timeout(pytestconfig):
    limit = float(pytestconfig.getini("timeout"))
    late = []
    for path in sorted((ROOT / "tests").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.Call) or (
                    isinstance(node.func, ast.Attribute) and node.func.attr == "timeout"):
                continue  # pytest.mark.timeout(...) sets a test's own limit
            late += [f"{path.relative_to(ROOT)}:{node.lineno}: timeout={k.value.value}"
                     for k in node.keywords if k.arg == "timeout"
                     and isinstance(k.value, ast.Constant) and k.value.value >= limit]
    assert not late, f"subprocess timeouts not below pytest-timeout's {limit} s: {late}"
