"""Specification: the utilities every package uses sit at the bottom, in ``dlo_env.core``; they
import none of the project's packages, and their 0.2.0 locations still import."""

from __future__ import annotations

import ast
from pathlib import Path

import dlo_env.core

PROJECT = ("dlo_env", "latent_model", "planners", "dlo_bench", "dlo_cli")
#: What the core may import of the project: itself, and the input-error type its checks raise
#: (``dlo_env.errors``, a module that imports nothing of the project).
ALLOWED = ("dlo_env.core", "dlo_env.errors")


def _imported(path: Path) -> set[str]:
    """Every module ``path`` imports, inside functions too (a relative import: the core's)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            names.add("dlo_env.core" if node.level else str(node.module))
    return names


def test_the_core_imports_none_of_the_projects_packages():
    folder = Path(dlo_env.core.__file__).parent
    upward = sorted(f"{path.name} imports {name}" for path in folder.glob("*.py")
                    for name in _imported(path)
                    if name.split(".")[0] in PROJECT
                    and not any(name == a or name.startswith(a + ".") for a in ALLOWED))
    assert upward == []


def test_the_documented_old_locations_import_the_same_objects():
    import dlo_env.core.ray_backend
    import dlo_env.dataset.ray_backend
    import planners.episodes
    import planners.episodic_policy

    assert dlo_env.dataset.ray_backend.RayBackend is dlo_env.core.ray_backend.RayBackend
    for name in planners.episodes.__all__:
        assert getattr(planners.episodes, name) is getattr(planners.episodic_policy, name)
