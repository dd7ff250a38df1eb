"""``dlo benchmark --quick`` in a clean checkout leaves ``git status`` clean and finds every agent.

The checkout is what the command reads of the repository's tracked files, as they are now (the
packages, with their shipped models, and ``.gitignore``), committed to a fresh git repository;
the command runs from it with its default output folder.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: Seconds of the test's pytest-timeout left to the checkout and the import check, not the
#: benchmark.
SETUP_SECONDS = 120


def _git(*args: str, cwd: Path) -> str:
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True,
                          text=True, timeout=120).stdout


@pytest.fixture
def checkout(tmp_path) -> Path:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs git and a git checkout of the project")
    clone = tmp_path / "clone"
    # All of the tracked tree the command reads: the packages (the folders with an
    # __init__.py) with their shipped models, and the ignore rules that keep runs/ out of
    # git status.
    packages = {name.split("/")[0] for name in _git("ls-files", "*/__init__.py", cwd=ROOT).split()
                if "/" in name}
    for name in _git("ls-files", "-z", "--", *sorted(packages), ".gitignore",
                     cwd=ROOT).split("\0"):
        source = ROOT / name
        if name and source.is_file():  # tracked files deleted in the working tree are skipped
            (clone / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, clone / name)
    _git("init", "-q", cwd=clone)
    _git("add", "-A", cwd=clone)
    _git("-c", "user.name=test", "-c", "user.email=test@example.org", "commit", "-qm", "clean",
         cwd=clone)
    return clone


@pytest.mark.slow
def test_quick_benchmark_in_a_clean_checkout_writes_under_runs_and_changes_no_tracked_file(
        checkout, request):
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    where = subprocess.run([sys.executable, "-c", "import dlo_bench; print(dlo_bench.__file__)"],
                           cwd=checkout, env=env, capture_output=True, text=True, timeout=60)
    assert Path(where.stdout.strip()).is_relative_to(checkout)  # the checkout's own code runs
    code = "import sys; from dlo_cli.main import main; sys.exit(main(sys.argv[1:]))"
    done = subprocess.run([sys.executable, "-c", code, "benchmark", "--quick", "--difficulty",
                           "1"], cwd=checkout, env=env, capture_output=True, text=True,
                          timeout=float(request.config.getini("timeout")) - SETUP_SECONDS)
    assert done.returncode == 0, done.stderr[-2000:]
    assert _git("status", "--porcelain", "--untracked-files=all", cwd=checkout) == ""
    rows = json.loads((checkout / "runs" / "benchmark" / "results.json").read_text())
    endpoint = [r for r in rows if r["env"] == "endpoint"]
    assert endpoint and all(r["status"] == "ok" for r in endpoint), [r["note"] for r in rows]
    for r in rows:  # the dual environment: a shipped agent runs, the others say why not
        assert r["status"] == "ok" or r["note"].startswith(("acts only in", "no trained model")), r
