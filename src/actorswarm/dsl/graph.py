"""The Actor state machine of a task script as a diagram (Mermaid or Graphviz dot).

:func:`state_edges` turns the model into one table of edges — the platforms starting each
initial actor, one edge per branch, and one per timeout — and both renderers only draw that
table, so the two formats always show the same machine.

Labels carry what decides when an edge is taken: the event, how many platforms take it
(``2 of 10`` for a branch, ``10`` or ``all`` when one successor takes every participant,
``rest of 10`` for a ``cnt="rest"`` branch) and the barrier key. A timeout edge goes to the
``timeoutBranch`` (or back to the same actor when there is none); dot draws it dashed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from actorswarm.dsl.model import Branch, TaskScript, Transition
from actorswarm.dsl.syntax import id_ranges
from actorswarm.dsl.writer import number

EdgeKind = Literal["start", "branch", "timeout"]
#: The source of the ``start`` edges: where every platform begins.
START = "[*]"


@dataclass(frozen=True, slots=True, kw_only=True)
class Edge:
    """One arrow of the diagram: from ``source`` (an actor, or :data:`START`) to ``target``."""

    source: str
    target: str
    label: str
    kind: EdgeKind


def _share(transition: Transition, branch: Branch) -> str:
    total = str(transition.sys_num)
    if len(transition.branches) == 1 and branch.count == "rest":
        return total
    return f"{branch.count} of {total}"


def _key(transition: Transition) -> str:
    return "" if transition.barrier_key is None else f", key {transition.barrier_key}"


def state_edges(script: TaskScript) -> tuple[Edge, ...]:
    """Every edge of the state machine: starts first, then each transition's branches and
    timeout, in script order."""
    found = [
        Edge(
            source=START,
            target=actor,
            label=f"platform{'s' if len(ids) > 1 else ''} {id_ranges(ids)}",
            kind="start",
        )
        for actor, ids in script.initial_actors().items()
    ]
    for transition in script.all_transitions():
        found += [
            Edge(
                source=transition.actor,
                target=branch.successor,
                label=f"{transition.event} ({_share(transition, branch)}{_key(transition)})",
                kind="branch",
            )
            for branch in transition.branches
        ]
        if transition.timeout is not None:
            found.append(
                Edge(
                    source=transition.actor,
                    target=transition.timeout_branch or transition.actor,
                    label=f"timeout {number(transition.timeout)} s ({transition.event})",
                    kind="timeout",
                )
            )
    return tuple(found)


_MERMAID_ID = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
# Words that start a statement in a Mermaid state diagram and so cannot name a state.
_MERMAID_WORDS = {"state", "note", "end", "direction", "classdef", "class", "style", "click"}


def to_mermaid(script: TaskScript) -> str:
    """A Mermaid ``stateDiagram-v2`` of ``script``; actors whose names Mermaid cannot take
    as identifiers (``-`` or ``.`` in them, or a keyword) are declared under an alias."""
    ids: dict[str, str] = {}
    lines = ["stateDiagram-v2"]
    for index, actor in enumerate(script.actors, start=1):
        name = actor.name
        if _MERMAID_ID.fullmatch(name) and name.lower() not in _MERMAID_WORDS:
            ids[name] = name
        else:
            ids[name] = f"actor_{index}"
            lines.append(f'    state "{name}" as {ids[name]}')
    for edge in state_edges(script):
        source = "[*]" if edge.kind == "start" else ids.get(edge.source, edge.source)
        target = ids.get(edge.target, edge.target)
        lines.append(f"    {source} --> {target} : {edge.label}")
    return "\n".join(lines) + "\n"


def _dot_quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def to_dot(script: TaskScript) -> str:
    """A Graphviz ``digraph`` of ``script``: initial actors drawn with a double border and
    an arrow from a start point labelled with their platforms; timeout edges dashed."""
    initial = script.initial_actors()
    lines = [
        f"digraph {_dot_quote(script.name)} {{",
        "    rankdir=LR;",
        "    node [shape=box, style=rounded];",
        '    "__start__" [shape=point, label=""];',
    ]
    for actor in script.actors:
        extra = ", peripheries=2" if actor.name in initial else ""
        lines.append(f"    {_dot_quote(actor.name)} [label={_dot_quote(actor.name)}{extra}];")
    for edge in state_edges(script):
        source = '"__start__"' if edge.kind == "start" else _dot_quote(edge.source)
        style = ", style=dashed" if edge.kind == "timeout" else ""
        lines.append(
            f"    {source} -> {_dot_quote(edge.target)} [label={_dot_quote(edge.label)}{style}];"
        )
    lines.append("}")
    return "\n".join(lines) + "\n"
