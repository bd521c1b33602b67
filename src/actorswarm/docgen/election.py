"""The election rules of :mod:`actorswarm.core.election`, rendered for docs/collective-core.md.

The block between ``<!-- election-table:begin -->`` and ``<!-- election-table:end -->`` in
that document is generated: two markdown tables
(:data:`~actorswarm.core.election.HEARTBEAT_RULES`,
:data:`~actorswarm.core.election.CLAIM_RULES`) and a Mermaid ``stateDiagram-v2`` of the role
transitions their rows imply (:data:`~actorswarm.core.election.ENTERS`; a claim makes a
platform master)::

    python -m actorswarm.docgen.election           # print the block
    python -m actorswarm.docgen.election --write   # rewrite the block in the document
    python -m actorswarm.docgen.election --check   # exit 1 with a diff if it is stale

Nothing outside the markers is touched.
"""

from __future__ import annotations

import argparse
import difflib
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, Final

from actorswarm.core.election import CLAIM_RULES, ENTERS, HEARTBEAT_RULES, Role, Rule

BEGIN: Final = "<!-- election-table:begin -->"
END: Final = "<!-- election-table:end -->"
COMMAND: Final = "python -m actorswarm.docgen.election --write"
#: docs/collective-core.md of the source tree this module belongs to.
DOC: Final = Path(__file__).resolve().parents[3] / "docs" / "collective-core.md"

_STATE_NAMES: Final = {
    Role.MASTER: "master",
    Role.FOLLOWER: "follower (live master)",
    Role.MASTERLESS: "masterless",
}


def _roles(roles: frozenset[Role]) -> str:
    if roles == frozenset(Role):
        return "any"
    return " or ".join(role.value for role in Role if role in roles)


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(text) for text in row) + " |" for row in rows]
    return lines


def heartbeat_table() -> list[str]:
    """:data:`HEARTBEAT_RULES` as markdown table lines, one row per rule, in order."""
    rows = [(r.name, _roles(r.roles), r.when, f"`{r.then.name}`", r.why) for r in HEARTBEAT_RULES]
    return _table(("Rule", "This platform", "The heartbeat shows", "Action", "Why"), rows)


def claim_table() -> list[str]:
    """:data:`CLAIM_RULES` as markdown table lines, one row per rule, in order."""
    rows = [
        (r.name, _roles(r.roles), r.when, "yes" if r.then else "no", r.why) for r in CLAIM_RULES
    ]
    return _table(("Rule", "This platform", "When", "Claims", "Why"), rows)


def transitions() -> dict[tuple[Role, Role, str], list[str]]:
    """(from, to, action) → the rules that make that transition, in table order.

    A heartbeat rule moves a platform in each of its roles to the role its action enters
    (IGNORE: none); a claim rule that claims moves it to master.
    """
    moves: dict[tuple[Role, Role, str], list[str]] = {}
    rules: list[tuple[Rule[Any, Any], Role | None, str]] = [
        (r, ENTERS[r.then], r.then.name) for r in HEARTBEAT_RULES
    ]
    rules += [(r, Role.MASTER if r.then else None, "claim") for r in CLAIM_RULES]
    for rule, target, label in rules:
        if target is None:
            continue
        for source in (role for role in Role if role in rule.roles):
            moves.setdefault((source, target, label), []).append(rule.name)
    return moves


def mermaid() -> list[str]:
    """A Mermaid ``stateDiagram-v2`` of the roles and :func:`transitions`."""
    lines = ["stateDiagram-v2"]
    lines += [f'    state "{name}" as {role.value}' for role, name in _STATE_NAMES.items()]
    lines.append(f"    [*] --> {Role.MASTERLESS.value} : boot")
    for (source, target, label), names in transitions().items():
        lines.append(f"    {source.value} --> {target.value} : {label} ({', '.join(names)})")
    return lines


def render() -> str:
    """The generated block, without its markers."""
    lines = [
        f"<!-- Generated from src/actorswarm/core/election.py by `{COMMAND}`. -->",
        "",
        "The rules, as the code evaluates them: a platform takes the first row for its role",
        "that applies. A *follower* follows a live master; a *masterless* platform follows",
        "none (booting, master lost, cut off). H rules answer a heartbeat (or a `Sync`, which",
        "shows a master); C rules decide whether to claim the master role.",
        "",
        *heartbeat_table(),
        "",
        *claim_table(),
        "",
        "```mermaid",
        *mermaid(),
        "```",
    ]
    return "\n".join(lines) + "\n"


def splice(text: str, block: str) -> str:
    """``text`` with the lines between the markers replaced by ``block``.

    Raises ValueError unless ``text`` holds exactly one begin marker followed by one end
    marker, each on a line of its own.
    """
    lines = text.splitlines(keepends=True)
    begins = [i for i, line in enumerate(lines) if line.strip() == BEGIN]
    ends = [i for i, line in enumerate(lines) if line.strip() == END]
    if len(begins) != 1 or len(ends) != 1 or ends[0] < begins[0]:
        raise ValueError(f"expected one {BEGIN} line followed by one {END} line")
    return "".join([*lines[: begins[0] + 1], block, *lines[ends[0] :]])


def main(argv: Sequence[str] | None = None) -> int:
    """The command line: 0 when done or up to date, 1 when ``--check`` finds the document
    stale (a unified diff goes to stdout), 2 when its markers are missing."""
    parser = argparse.ArgumentParser(
        prog="python -m actorswarm.docgen.election", description=__doc__.splitlines()[0]
    )
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true", help="rewrite the block in the document")
    mode.add_argument("--check", action="store_true", help="exit 1 if the block is stale")
    parser.add_argument("--doc", type=Path, default=DOC, help=f"the document (default {DOC})")
    args = parser.parse_args(argv)
    block = render()
    if not (args.write or args.check):
        sys.stdout.write(block)
        return 0
    text = args.doc.read_text(encoding="utf-8")
    try:
        wanted = splice(text, block)
    except ValueError as exc:
        print(f"{args.doc}: {exc}", file=sys.stderr)
        return 2
    if wanted == text:
        print(f"{args.doc}: election rules up to date")
        return 0
    if args.write:
        args.doc.write_text(wanted, encoding="utf-8")
        print(f"{args.doc}: election rules rewritten")
        return 0
    diff = difflib.unified_diff(
        text.splitlines(keepends=True),
        wanted.splitlines(keepends=True),
        f"{args.doc} (now)",
        f"{args.doc} (generated)",
    )
    sys.stdout.writelines(diff)
    print(f"{args.doc}: election rules out of date; regenerate with: {COMMAND}", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
