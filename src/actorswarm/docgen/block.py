"""One generated block of a document: where it sits (two marker lines), how it is rendered,
and the command line that prints, writes or checks it.

A document keeps its generated block between a begin and an end marker, each on a line of
its own; nothing outside them is ever touched.
"""

from __future__ import annotations

import argparse
import difflib
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["GeneratedBlock", "splice"]


def splice(text: str, block: str, begin: str, end: str) -> str:
    """``text`` with the lines between the markers replaced by ``block``.

    Raises ValueError unless ``text`` holds exactly one ``begin`` line followed by one
    ``end`` line.
    """
    lines = text.splitlines(keepends=True)
    begins = [i for i, line in enumerate(lines) if line.strip() == begin]
    ends = [i for i, line in enumerate(lines) if line.strip() == end]
    if len(begins) != 1 or len(ends) != 1 or ends[0] < begins[0]:
        raise ValueError(f"expected one {begin} line followed by one {end} line")
    return "".join([*lines[: begins[0] + 1], block, *lines[ends[0] :]])


@dataclass(frozen=True)
class GeneratedBlock:
    """A block of ``doc`` between ``begin`` and ``end``, made by ``render``; ``what`` names
    it in messages, ``command`` is the line that regenerates it."""

    what: str
    doc: Path
    begin: str
    end: str
    command: str
    render: Callable[[], str]

    def main(self, argv: Sequence[str] | None = None) -> int:
        """The command line: 0 when done or up to date, 1 when ``--check`` finds the
        document stale (a unified diff goes to stdout), 2 when its markers are missing."""
        parser = argparse.ArgumentParser(
            prog=self.command.removesuffix(" --write"), description=f"Generate {self.what}."
        )
        mode = parser.add_mutually_exclusive_group()
        mode.add_argument("--write", action="store_true", help="rewrite the block")
        mode.add_argument("--check", action="store_true", help="exit 1 if the block is stale")
        parser.add_argument(
            "--doc", type=Path, default=self.doc, help=f"the document (default {self.doc})"
        )
        args = parser.parse_args(argv)
        block = self.render()
        if not (args.write or args.check):
            sys.stdout.write(block)
            return 0
        text = args.doc.read_text(encoding="utf-8")
        try:
            wanted = splice(text, block, self.begin, self.end)
        except ValueError as exc:
            print(f"{args.doc}: {exc}", file=sys.stderr)
            return 2
        if wanted == text:
            print(f"{args.doc}: {self.what} up to date")
            return 0
        if args.write:
            args.doc.write_text(wanted, encoding="utf-8")
            print(f"{args.doc}: {self.what} rewritten")
            return 0
        diff = difflib.unified_diff(
            text.splitlines(keepends=True),
            wanted.splitlines(keepends=True),
            f"{args.doc} (now)",
            f"{args.doc} (generated)",
        )
        sys.stdout.writelines(diff)
        print(
            f"{args.doc}: {self.what} out of date; regenerate with: {self.command}",
            file=sys.stderr,
        )
        return 1
