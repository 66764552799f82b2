"""The documentation's shape (issue 39): every page is in mkdocs.yml's nav and linked from
docs/index.md, and the time a make target takes is stated in one place, the measured table of
docs/validation.md, which every other mention points to."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
LINK = re.compile(r"\]\(([^)#\s]+\.md)(?:#[^)]*)?\)")
DURATION = re.compile(r"\b\d+(?:\.\d+)?\s?(?:s|min|minutes?|seconds?|h)\b|under a minute")
TARGET = re.compile(r"make (?:run|test|test-fast|fuzz|bench)\b")


def nav_pages(entries) -> list[str]:
    """The page paths of a mkdocs nav (nested sections flattened)."""
    pages = []
    for entry in entries:
        value = next(iter(entry.values())) if isinstance(entry, dict) else entry
        pages += nav_pages(value) if isinstance(value, list) else [value]
    return pages


def test_every_page_is_in_the_nav_and_the_nav_names_only_pages():
    nav = nav_pages(yaml.safe_load((ROOT / "mkdocs.yml").read_text())["nav"])
    on_disk = sorted(str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md"))
    assert sorted(nav) == on_disk


def test_the_home_page_links_every_page():
    """A reader who starts at docs/index.md sees a link to every page of the nav."""
    nav = nav_pages(yaml.safe_load((ROOT / "mkdocs.yml").read_text())["nav"])
    linked = {str((DOCS / target).resolve().relative_to(DOCS)) for target in LINK.findall((DOCS / "index.md").read_text())}
    assert sorted(set(nav) - linked - {"index.md"}) == []


def test_times_of_the_make_targets_live_only_in_the_measured_table():
    """A sentence (or a Makefile comment) that names a make target states no duration, except in
    docs/validation.md, whose table says what was measured and on which machine."""
    stated = []
    for page in [*DOCS.rglob("*.md"), ROOT / "README.md", ROOT / "Makefile"]:
        if page == DOCS / "validation.md":
            continue
        text = page.read_text()
        if page.name == "Makefile":  # a comment describes the target below it
            text = re.sub(r"((?:^#.*\n)+)(?=[\w.-]+:)", lambda m: m.group(1).replace("\n", " ") + "make ", text, flags=re.M)
        for sentence in re.split(r"(?<=[.;])\s+(?=[A-Z`(])|(?<=:)\s+|\n\s*\n|\n(?=[-*#] )", text):
            if TARGET.search(sentence) and DURATION.search(sentence):
                stated.append(f"{page.relative_to(ROOT)}: {' '.join(sentence.split())[:160]}")
    assert stated == []
    table = (DOCS / "validation.md").read_text().split("## Measured times", 1)[1].split("\n## ", 1)[0]
    assert "Machine:" in table and all(target in table for target in ("`make run`", "`make test`", "`make test-fast`"))
