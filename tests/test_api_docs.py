"""The documentation site builds with ``mkdocs build --strict``: the guide pages of docs/, the
API reference made from the docstrings, and the changelog. A reference to a name that no longer
exists, a docstring argument its signature lacks, or a page left out of the nav fails the build.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mkdocs", reason="the docs extra is not installed (pip install -e '.[docs]')")
pytest.importorskip("mkdocstrings", reason="the docs extra is not installed "
                    "(pip install -e '.[docs]')")
yaml = pytest.importorskip("yaml")

ROOT = Path(__file__).resolve().parent.parent


def _build(config: Path, site: Path, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(config),
         "--site-dir", str(site)],
        cwd=cwd, capture_output=True, text=True, timeout=300)


def test_the_site_builds_strictly_with_every_package_documented(tmp_path):
    result = _build(ROOT / "mkdocs.yml", tmp_path / "site", ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    api = tmp_path / "site" / "api"
    for name in ("dlo_env.envs.DLOEndpointEnv", "latent_model.TransitionModel",
                 "planners.LatentMPCPolicy", "dlo_bench.build_agent"):
        package = name.split(".")[0]
        assert f'id="{name}"' in (api / package / "index.html").read_text(), name
    assert "Keep a Changelog" in (tmp_path / "site" / "changelog" / "index.html").read_text()


def test_a_docstring_argument_the_signature_lacks_fails_the_build(tmp_path):
    """The project's settings turn a stale docstring into a failed build (not a silent page)."""
    (tmp_path / "docs").mkdir()
    (tmp_path / "stale.py").write_text(
        'def move(shape):\n    """Move it.\n\n    Args:\n        shape: The shape.\n'
        '        grasp: The held end, an argument that is gone.\n    """\n')
    (tmp_path / "docs" / "index.md").write_text("# Stale\n\n::: stale.move\n")
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    config["nav"] = [{"Home": "index.md"}]
    config["markdown_extensions"] = []
    plugin = next(p for p in config["plugins"] if isinstance(p, dict) and "mkdocstrings" in p)
    plugin["mkdocstrings"]["handlers"]["python"]["paths"] = [str(tmp_path)]
    (tmp_path / "mkdocs.yml").write_text(yaml.safe_dump(config))
    result = _build(tmp_path / "mkdocs.yml", tmp_path / "site", tmp_path)
    assert result.returncode != 0
    assert "grasp" in result.stdout + result.stderr
