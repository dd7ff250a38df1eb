"""Every relative link of the README and docs/ points at a file that exists, and every
``#anchor`` at a heading of that file (GitHub's anchors); so does every page or README section
the code names."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")
#: The code whose docstrings and comments name pages: the packages, examples, benchmarks.
SOURCES = sorted(p for folder in ("dlo_env", "latent_model", "planners", "dlo_bench", "dlo_cli",
                                  "examples", "benchmarks")
                 for p in (ROOT / folder).rglob("*.py"))
#: ``docs/page.md`` or ``docs/page.md#anchor``.
PAGE = re.compile(r"docs/([\w-]+\.md)(?:#([\w-]+))?")
#: ``README "Heading"`` or ``README section "Heading"``.
SECTION = re.compile(r'README\s+(?:section\s+)?"([^"]+)"')


def _anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = heading.strip().lstrip("#").strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # no headings in code
    return {_anchor(line) for line in text.splitlines() if line.startswith("#")}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_relative_links_resolve(page):
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    broken = []
    for target in LINK.findall(text):
        if re.match(r"[a-z]+:", target):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if not file.exists():
            broken.append(target)
        elif anchor and file.suffix == ".md" and anchor not in _anchors(file):
            broken.append(target)
    assert not broken, f"{page.name}: broken links {broken}"


def test_the_pages_and_readme_sections_the_code_names_exist():
    readme = re.sub(r"```.*?```", "", (ROOT / "README.md").read_text(), flags=re.S)
    headings = {line.lstrip("#").strip().lower() for line in readme.splitlines()
                if line.startswith("#")}
    broken = []
    for source in SOURCES:
        text = source.read_text()
        name = source.relative_to(ROOT)
        for page, anchor in PAGE.findall(text):
            file = ROOT / "docs" / page
            if not file.exists() or (anchor and anchor not in _anchors(file)):
                broken.append(f"{name}: docs/{page}{'#' * bool(anchor)}{anchor}")
        broken += [f'{name}: README "{h}"' for h in SECTION.findall(text)
                   if h.lower() not in headings]
    assert not broken, f"names of pages or sections that do not exist: {broken}"
