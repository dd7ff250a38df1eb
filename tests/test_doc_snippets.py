"""Every Python example of the README and docs/ runs on its own, as a reader pastes it.

Each ```python block is run alone in a fresh namespace (in a temporary working folder, so the
files an example writes go there). A block that needs a file the reader makes first says so
in an HTML comment on the line before it, ``<!-- not run by tests/test_doc_snippets.py: ... -->``,
and is skipped with that reason.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"(?:<!-- (not run by [^>]*?) -->\n)?```python\n(.*?)```", re.S)


def _blocks() -> list:
    cases = []
    for page in PAGES:
        for k, match in enumerate(BLOCK.finditer(page.read_text())):
            skip, code = match.groups()
            marks = [pytest.mark.skip(reason=skip)] if skip else []
            cases.append(pytest.param(code, id=f"{page.name}-{k + 1}", marks=marks))
    return cases


@pytest.mark.slow
@pytest.mark.parametrize("code", _blocks())
def test_the_example_runs_on_its_own(code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<example>", "exec"), {"__name__": "__example__"})


def test_every_page_with_examples_is_found():
    ids = [case.id for case in _blocks()]
    assert any(i.startswith("README.md-") for i in ids)
    assert any(i.startswith("environments.md-") for i in ids)
