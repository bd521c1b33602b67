"""The docs hold: every link between them (README.md and docs/**/*.md) reaches a file, and
its #anchor a heading of that file; every ``actorswarm ...`` command line they show names a
command that exists, with options that command has."""

from __future__ import annotations

import re
import shlex
from collections.abc import Iterator
from functools import cache
from pathlib import Path
from typing import Any

import pytest
import typer.main

from actorswarm.cli.app import app

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]

LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^\s*(```|~~~)")


def _rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


def _prose(text: str) -> str:
    """``text`` without its fenced code blocks (links there are not links)."""
    out, inside = [], False
    for line in text.splitlines():
        if FENCE.match(line):
            inside = not inside
            continue
        if not inside:
            out.append(line)
    return "\n".join(out)


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"`|\*\*|\*|_(?=\W)|(?<=\W)_", "", heading.strip()).lower()
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link: its text
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


@cache
def _anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    anchors = set()
    for line in _prose(path.read_text(encoding="utf-8")).splitlines():
        m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        slug = _slug(m.group(1))
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        anchors.add(slug if n == 0 else f"{slug}-{n}")
    anchors.update(re.findall(r'<a\s+(?:name|id)="([^"]+)"', path.read_text(encoding="utf-8")))
    return anchors


def _links() -> Iterator[tuple[Path, str]]:
    for doc in DOCS:
        for m in LINK.finditer(_prose(doc.read_text(encoding="utf-8"))):
            target = m.group(1) or m.group(2)
            if not re.match(r"[a-z]+:", target):  # http:, mailto: ... are not followed
                yield doc, target


LINKS = list(_links())


@pytest.mark.parametrize(("doc", "target"), LINKS, ids=[f"{_rel(d)}->{t}" for d, t in LINKS])
def test_a_link_between_the_docs_reaches_its_file_and_heading(doc: Path, target: str) -> None:
    path_part, _, anchor = target.partition("#")
    dest = (doc.parent / path_part).resolve() if path_part else doc
    assert dest.exists(), f"{_rel(doc)}: link to {target}: no such file"
    if anchor and dest.suffix == ".md":
        assert anchor in _anchors(dest), (
            f"{_rel(doc)}: link to {target}: no such heading in {dest.name}; "
            f"its anchors: {sorted(_anchors(dest))}"
        )


#: Where a command line starts: a prompt, variables, sudo, a path to the program.
START = re.compile(
    r"(?:^|[;&|(]\s*)(?:\$\s+)?(?:[A-Z_]+=\S*\s+)*(?:sudo\s+(?:-u\s+\S+\s+)?)?"
    r"(?:[\w./~-]*/)?(actorswarm\s+[a-z-].*)"
)


#: Inline code that names a command without the program: `sim --world W.toml`.
BARE = re.compile(
    r"(?:sim|demo|launch|daemon|plot|web|autopilot|(?:gs|task|bench|keys|swarm) [a-z]+)\s+--"
)


def _command_lines(text: str) -> Iterator[str]:
    """``actorswarm ...`` command lines: in code blocks (continuations joined) and in
    inline code."""
    inside = False
    pending = ""
    for line in text.splitlines():
        if FENCE.match(line):
            inside = not inside
            pending = ""
            continue
        if inside:
            pending = f"{pending} {line.strip()}" if pending else line.strip()
            if pending.endswith("\\"):
                pending = pending[:-1]
                continue
            found = None if pending.startswith("#") else START.search(pending)
            if found:
                yield found.group(1)
            pending = ""
        else:
            for span in re.findall(r"`([^`]+)`", line):
                found = START.match(span)
                if found:
                    yield found.group(1)
                elif BARE.match(span):
                    yield f"actorswarm {span}"


def _cases() -> Iterator[tuple[Path, str]]:
    for doc in DOCS:
        seen = set()
        for line in _command_lines(doc.read_text(encoding="utf-8")):
            if line not in seen:
                seen.add(line)
                yield doc, line


COMMAND_LINES = list(_cases())


def _words(line: str) -> list[str]:
    line = re.split(r"\s(?:\||&&|;|>|2>|&>|#)\s?|\s&$", line)[0]
    try:
        return shlex.split(line)
    except ValueError:
        return line.split()


@cache
def _root() -> Any:
    return typer.main.get_command(app)


def _resolve(words: list[str]) -> tuple[Any, list[str], list[str]]:
    """The command the words name, the path to it, and the words after it."""
    cmd: Any = _root()
    path: list[str] = []
    rest = words[1:]
    while hasattr(cmd, "commands") and rest and not rest[0].startswith("-"):
        if rest[0] not in cmd.commands:
            break
        path.append(rest[0])
        cmd = cmd.commands[rest[0]]
        rest = rest[1:]
    return cmd, path, rest


@pytest.mark.parametrize(
    ("doc", "line"), COMMAND_LINES, ids=[f"{_rel(d)}:{line[:60]}" for d, line in COMMAND_LINES]
)
def test_a_documented_command_line_exists(doc: Path, line: str) -> None:
    words = _words(line)
    cmd, path, rest = _resolve(words)
    where = f"{_rel(doc)}: `{line}`"
    if hasattr(cmd, "commands"):
        # A group: either named alone (`actorswarm gs`), or followed by a command it has.
        assert (
            not rest or rest[0].startswith("-") or not re.fullmatch(r"[a-z][a-z0-9-]*", rest[0])
        ), f"{where}: no command {' '.join(path + rest[:1])!r}"
    known = {"--help"} | {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)}
    for word in rest:
        if not word.startswith("--") or word == "--":
            continue
        name = word.split("=", 1)[0]
        if name.strip("-.…") == "" or not re.fullmatch(r"--[a-z][a-z0-9-]*", name):
            continue  # `--...`, a placeholder
        assert name in known, f"{where}: actorswarm {' '.join(path)} has no option {name}"
