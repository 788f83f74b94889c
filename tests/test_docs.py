"""The README and docs/*.md as a newcomer meets them: the README fits a
screen (what Argand is, the picture and both commands in its first 60
lines, 150 lines in all), every relative link and anchor resolves, and
every repository path the docs name exists (a file moved without its docs
fails here)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
#: Paths that stand for a family of files, not one file.
PLACEHOLDERS = {"src/argand/X/Y.py"}


def test_the_readme_fits_a_screen():
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= 150
    first = "\n".join(lines[:60])
    assert lines[0] == "# Argand" and "algebraic surfaces in complex space" in first
    assert "](docs/bench/render_contact.png)" in first
    assert re.search(r"^make run\b", first, re.M) and re.search(r"^make test\b", first, re.M)


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    return {slug(m.group(1)) for m in re.finditer(r"^#+ (.+)$", text, re.M)}


@pytest.mark.parametrize("doc", PAGES, ids=[str(p.relative_to(REPO)) for p in PAGES])
def test_links_resolve(doc):
    broken = []
    for target, anchor in re.findall(r"\]\(([^)#\s]*)(#[^)\s]*)?\)", doc.read_text()):
        if target.startswith(("http://", "https://", "mailto:")):
            continue
        path = (doc.parent / target).resolve() if target else doc
        if not path.exists():
            broken.append(target)
        elif anchor and path.suffix == ".md" and anchor[1:] not in anchors(path):
            broken.append(target + anchor)
    assert broken == []


#: A path in the repository with a file's extension, not part of a longer path.
PATH = re.compile(r"(?<![\w/.-])((?:src|tests|core|deploy|fuzz|scenes)/[\w/.-]*?\.(?:py|pyi|h|cpp|md|yml|yaml|conf|"
                  r"txt|toml|sh|js|css|html))(?![\w.])")


def named_paths(doc: Path) -> set[str]:
    return set(PATH.findall(doc.read_text())) - PLACEHOLDERS


def test_the_path_pattern_finds_the_paths_the_docs_name():
    named = set().union(*(named_paths(doc) for doc in PAGES))
    assert {"src/argand/farm/tile_work.py", "core/src/root_kernels.h", "tests/helpers/truth.py"} <= named
    assert not any(p.endswith(".cpp.o") or "CMakeFiles" in p for p in named)


@pytest.mark.parametrize("doc", PAGES, ids=[str(p.relative_to(REPO)) for p in PAGES])
def test_named_paths_exist(doc):
    assert sorted(p for p in named_paths(doc) if not (REPO / p).exists()) == []
