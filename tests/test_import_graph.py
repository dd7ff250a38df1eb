"""Specification: dependencies point one way. No import cycle between the project's files,
counting imports inside functions and a module's import of its own package's ``__init__``."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The packages checked. dlo_cli is not yet: its collect commands import each other until they
#: become ``dlo collect shapes|transitions`` subcommands.
PACKAGES = ("dlo_env", "latent_model", "planners", "dlo_bench", "dlo_cli")


def _modules() -> dict[str, Path]:
    modules = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            modules[name.removesuffix(".__init__")] = path
    return modules


def _targets(name: str, path: Path) -> set[str]:
    """The modules ``name`` (at ``path``) imports: for ``from P import N``, ``P`` and ``P.N``."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package[:len(package) - (node.level - 1)]
                base = ".".join(parts + ([node.module] if node.module else []))
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()

    def known(target: str) -> str:
        while target and target not in modules:
            target = target.rpartition(".")[0]
        return target

    return {name: {known(t) for t in _targets(name, path)} - {"", name}
            for name, path in modules.items()}


def _a_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle of ``graph`` as the modules along it (empty: none)."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str]:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                cycle = visit(nxt)
                if cycle:
                    return cycle
        path.pop()
        state[node] = 2
        return []

    for node in sorted(graph):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return []


def test_no_module_imports_a_module_that_imports_it_back():
    assert " -> ".join(_a_cycle(_graph())) == ""


def test_a_cycle_through_a_package_init_is_found():
    graph = {"pkg": {"pkg.a"}, "pkg.a": {"pkg"}, "pkg.b": set()}
    assert _a_cycle(graph) == ["pkg", "pkg.a", "pkg"]
