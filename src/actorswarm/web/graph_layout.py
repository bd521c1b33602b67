"""Where to draw each actor of the Actor state machine on the page.

The edges are those of ``actorswarm task graph`` (:func:`actorswarm.dsl.state_edges`), so
the page shows the same machine as the diagrams. The layout is layered, top to bottom (a
task reads as a sequence of phases, and the page's task panel is taller than wide):
initial actors in the first layer, every other actor one layer below its furthest
predecessor, ignoring the edges that close a cycle (found by a depth-first walk from the
initial actors, in script order); within a layer, actors sit near the mean place of their
predecessors. Edges that go back up are drawn on the right, where :data:`SIDE` is kept
free for them. That is enough for the scripts' small machines (a handful to a few dozen
actors) and keeps the page free of a graph-drawing library.
"""

from __future__ import annotations

from typing import Any

from actorswarm.dsl.graph import START, state_edges
from actorswarm.dsl.model import TaskScript
from actorswarm.dsl.syntax import id_ranges

__all__ = ["LEFT", "NODE_H", "NODE_W", "SIDE", "layout"]

NODE_W, NODE_H = 92.0, 28.0
GAP_X, GAP_Y = 40.0, 30.0
MARGIN = 14.0
#: Room on the left for loops and edges that skip layers, and on the right for the edges
#: that go back up, with their labels.
LEFT, SIDE = 96.0, 120.0


def _back_edges(
    names: list[str], succ: dict[str, list[str]], roots: list[str]
) -> set[tuple[str, str]]:
    """The edges that lead back to an actor on the current walk (they close cycles)."""
    state: dict[str, int] = {}  # 1: on the walk, 2: done
    back: set[tuple[str, str]] = set()
    for root in [*roots, *names]:
        if root in state:
            continue
        stack: list[tuple[str, int]] = [(root, 0)]
        state[root] = 1
        while stack:
            node, i = stack[-1]
            if i < len(succ[node]):
                stack[-1] = (node, i + 1)
                nxt = succ[node][i]
                if state.get(nxt) == 1:
                    back.add((node, nxt))
                elif nxt not in state:
                    state[nxt] = 1
                    stack.append((nxt, 0))
            else:
                state[node] = 2
                stack.pop()
    return back


def layout(script: TaskScript) -> dict[str, Any]:
    """JSON-ready: ``nodes`` (name, x, y, w, h, layer, initial platforms or ""), ``edges``
    (source, target, label, event, kind, back) and the drawing's ``width`` and ``height``.
    ``back`` marks an edge that goes to the same or an earlier layer."""
    names = [a.name for a in script.actors]
    edges = state_edges(script)
    succ: dict[str, list[str]] = {n: [] for n in names}
    for e in edges:
        if e.kind != "start" and e.target in succ and e.target not in succ[e.source]:
            succ[e.source].append(e.target)
    initial = script.initial_actors()
    roots = [n for n in names if n in initial]
    back = _back_edges(names, succ, roots)
    column = dict.fromkeys(names, 0)
    # Longest path over what is left (a DAG): relax in rounds, at most one per actor.
    for _ in names:
        changed = False
        for src in names:
            for dst in succ[src]:
                if (src, dst) not in back and src != dst and column[dst] < column[src] + 1:
                    column[dst] = column[src] + 1
                    changed = True
        if not changed:
            break
    columns: dict[int, list[str]] = {}
    for n in names:
        columns.setdefault(column[n], []).append(n)
    row: dict[str, float] = {}
    preds: dict[str, list[str]] = {n: [] for n in names}
    for src in names:
        for dst in succ[src]:
            if src != dst:
                preds[dst].append(src)
    for c in sorted(columns):
        members = columns[c]

        def centre(n: str) -> float:
            placed = [row[p] for p in preds[n] if p in row]
            return sum(placed) / len(placed) if placed else float(names.index(n))

        members.sort(key=lambda n: (centre(n), names.index(n)))
        for i, n in enumerate(members):
            row[n] = float(i)
    widest = max((len(m) for m in columns.values()), default=1)
    nodes = []
    for n in names:
        c = column[n]
        offset = (widest - len(columns[c])) / 2.0
        nodes.append(
            {
                "name": n,
                "x": LEFT + (row[n] + offset) * (NODE_W + GAP_X),
                "y": MARGIN + 12.0 + c * (NODE_H + GAP_Y),
                "w": NODE_W,
                "h": NODE_H,
                "layer": c,
                "initial": id_ranges(initial[n]) if n in initial else "",
            }
        )
    out_edges = [
        {
            "source": e.source,
            "target": e.target,
            "label": e.label,
            "event": e.label.split(" (")[0] if e.kind == "branch" else "",
            "kind": e.kind,
            "back": e.source == e.target or column.get(e.target, 0) <= column.get(e.source, 0),
        }
        for e in edges
        if e.source != START
    ]
    layers = max(column.values(), default=0) + 1
    width = LEFT + widest * (NODE_W + GAP_X) - GAP_X + SIDE
    height = MARGIN * 2 + 12.0 + layers * (NODE_H + GAP_Y) - GAP_Y
    return {"nodes": nodes, "edges": out_edges, "width": width, "height": height}
