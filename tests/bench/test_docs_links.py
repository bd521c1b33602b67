"""The benchmarks page and its history link only to files and headings that exist."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs" / "benchmarks"
PAGES = ("README.md", "history.md")
FENCE = re.compile(r"^```.*?^```", re.M | re.S)
LINK = re.compile(r"\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6} (.+)$", re.M)


def slug(title: str) -> str:
    """A heading's anchor as GitHub makes it: lower case, punctuation dropped, spaces → '-'."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """Every heading anchor of *page*, a repeated one numbered as GitHub numbers it."""
    seen: dict[str, int] = {}
    found = set()
    for title in HEADING.findall(FENCE.sub("", page.read_text(encoding="utf-8"))):
        base = slug(title)
        count = seen.get(base, 0)
        seen[base] = count + 1
        found.add(base if count == 0 else f"{base}-{count}")
    return found


def broken_links(page: Path) -> list[str]:
    """The relative links of *page* whose file or heading does not exist."""
    broken = []
    for link in LINK.findall(FENCE.sub("", page.read_text(encoding="utf-8"))):
        if re.match(r"^[a-z]+:", link):
            continue
        target, _, fragment = link.partition("#")
        path = (page.parent / target) if target else page
        missing_heading = bool(fragment) and (
            not path.exists() or path.suffix != ".md" or fragment not in anchors(path)
        )
        if not path.exists() or missing_heading:
            broken.append(link)
    return broken


@pytest.mark.parametrize("name", PAGES)
def test_every_link_of_the_page_resolves(name: str) -> None:
    page = DOCS / name
    assert LINK.search(page.read_text(encoding="utf-8")), f"{name} has no links to check"
    assert broken_links(page) == []


def test_a_missing_file_and_a_missing_heading_are_found(tmp_path: Path) -> None:
    (tmp_path / "other.md").write_text("# Present\n", encoding="utf-8")
    page = tmp_path / "page.md"
    page.write_text(
        "## A heading\n[ok](other.md#present) [self](#a-heading) "
        "[gone](missing.md) [no anchor](other.md#absent)\n",
        encoding="utf-8",
    )
    assert broken_links(page) == ["missing.md", "other.md#absent"]
