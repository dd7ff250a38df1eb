"""Every public top-level function and class of the library is used: named somewhere besides
its definition (the library, tests, examples, benchmarks, the docs)."""

from __future__ import annotations

import ast
import re
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("dlo_env", "latent_model", "planners", "dlo_bench", "dlo_cli")
READERS = ("tests", "examples", "benchmarks")


def test_every_public_function_and_class_of_the_library_is_used():
    library = sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))
    texts = [p.read_text() for p in library]
    texts += [p.read_text() for folder in READERS for p in (ROOT / folder).rglob("*.py")]
    texts += [p.read_text() for p in (ROOT / "docs").glob("*.md")]
    texts += [(ROOT / name).read_text() for name in ("README.md", "pyproject.toml")]
    words = Counter(word for text in texts for word in re.findall(r"\w+", text))
    unused = [f"{path.relative_to(ROOT)}: {node.name}"
              for path, text in zip(library, texts)
              for node in ast.parse(text).body
              if isinstance(node, (ast.FunctionDef, ast.ClassDef))
              and not node.name.startswith("_") and words[node.name] < 2]
    assert not unused, f"defined and never used: {unused}"
