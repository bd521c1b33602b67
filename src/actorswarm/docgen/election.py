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

import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, Final

from actorswarm.core.election import CLAIM_RULES, ENTERS, HEARTBEAT_RULES, Role, Rule
from actorswarm.docgen.block import GeneratedBlock
from actorswarm.docgen.block import splice as splice_block

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


BLOCK: Final = GeneratedBlock("election rules", DOC, BEGIN, END, COMMAND, render)


def splice(text: str, block: str) -> str:
    """``text`` with the election block replaced by ``block`` (see
    :func:`actorswarm.docgen.block.splice`)."""
    return splice_block(text, block, BEGIN, END)


def main(argv: Sequence[str] | None = None) -> int:
    """The command line (:meth:`actorswarm.docgen.block.GeneratedBlock.main`)."""
    return BLOCK.main(argv)


if __name__ == "__main__":
    sys.exit(main())
