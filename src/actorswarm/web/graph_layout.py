"""Where to draw each actor, edge and edge label of the Actor state machine on the page.

The edges are those of ``actorswarm task graph`` (:func:`actorswarm.dsl.state_edges`), so
the page shows the same machine as the diagrams. The drawing is layered, top to bottom (a
task reads as a sequence of phases), in the manner of Sugiyama and of Graphviz's ``dot``:

1. **Layers.** The edges that close a cycle (found by a depth-first walk from the initial
   actors, in script order) are turned around; every actor then sits one layer below its
   furthest predecessor (a longest path), the initial actors on top.
2. **Ranks.** Between two layers of actors lies a rank of *label slots*. Every edge is cut
   into one piece per rank it crosses, each piece ending at a slot, a dummy node; the
   slot in the rank just after the edge's start holds its label, as wide as the label.
   So a label is a box in a row of boxes like the actors themselves, and no label can
   cover another label or an actor — however many edges go into one actor (a recall
   from every actor). An edge within a layer (a back edge between neighbours) goes
   through a slot in the rank below; a loop sits on its actor's right, room kept there
   for it and its label.
3. **Order.** Within each rank, actors and slots are ordered to cross few edges: a few
   sweeps down and up, each sorting a rank by the mean place of its neighbours in the
   rank before (the barycentre heuristic).
4. **Places.** Each rank is packed left to right in that order, boxes kept
   :data:`GAP_X` apart, then pulled towards its neighbours' places over a few sweeps,
   keeping the order and the gaps.

An actor is as wide as its name (estimated from the characters; the page shrinks a name
that its font draws wider, never cuts it). A transition that branches to several actors
is labelled once, on its first edge; a timeout edge that goes where its transition's own
edge goes is folded into that edge (its tooltip gains the timeout).

The result is plain JSON for the page: it draws the boxes and the edges' points as given.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any

from actorswarm.dsl.graph import START, Edge, state_edges
from actorswarm.dsl.model import TaskScript
from actorswarm.dsl.syntax import id_ranges

__all__ = ["NODE_H", "label_width", "layout", "name_width"]

NODE_H = 28.0
#: A label slot's height.
LABEL_H = 15.0
#: The least width of an actor's box; room for the count pill and padding.
MIN_NODE_W, NODE_PAD = 64.0, 44.0
#: The least space between two boxes of a rank, and between two ranks.
GAP_X, GAP_Y = 14.0, 8.0
#: The width of a slot without a label (an edge passing through).
PASS_W = 6.0
MARGIN = 10.0
#: Room above the first layer for the start marks ("platforms 1-10").
TOP = 26.0
#: Room on an actor's right for a loop's curve.
LOOP_W = 26.0
_SWEEPS = 6

# Character widths in em of the page's sans-serif (DejaVu Sans, wide among the usual
# fonts): a generous estimate so that a name fits its box.
_BOLD = {"upper": 0.80, "lower": 0.66, "digit": 0.70, "_": 0.55, "other": 0.45}
_REGULAR = {"upper": 0.72, "lower": 0.60, "digit": 0.64, "_": 0.50, "other": 0.40}


def _width(text: str, size: float, widths: dict[str, float]) -> float:
    total = 0.0
    for c in text:
        if c.isupper():
            total += widths["upper"]
        elif c.islower():
            total += widths["lower"]
        elif c.isdigit():
            total += widths["digit"]
        elif c == "_":
            total += widths["_"]
        else:
            total += widths["other"]
    return total * size


def name_width(name: str) -> float:
    """The width an actor's box needs for ``name`` (bold 12 px) and its count."""
    return max(MIN_NODE_W, _width(name, 12.0, _BOLD) + NODE_PAD)


def label_width(text: str) -> float:
    """The width of an edge label (10.5 px)."""
    return _width(text, 10.5, _REGULAR) + 6.0


@dataclass(slots=True)
class _Box:
    """One box of a rank: an actor, or a slot an edge passes through (with its label)."""

    key: str
    rank: int
    w: float
    h: float
    actor: str = ""
    text: str = ""
    #: An actor's own width (its box ``w`` may add room for a loop on its right).
    core: float = 0.0
    x: float = 0.0  # the centre
    up: list[_Box] = field(default_factory=list)  # neighbours in the rank above
    down: list[_Box] = field(default_factory=list)  # and below


@dataclass(slots=True)
class _Drawn:
    """An edge as drawn: its edges of the task graph (the first one names it), its label."""

    edges: list[Edge]
    text: str
    boxes: list[_Box] = field(default_factory=list)


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


def _layers(script: TaskScript, edges: list[Edge]) -> tuple[dict[str, int], set[tuple[str, str]]]:
    names = [a.name for a in script.actors]
    succ: dict[str, list[str]] = {n: [] for n in names}
    for e in edges:
        if e.source in succ and e.target in succ and e.target not in succ[e.source]:
            succ[e.source].append(e.target)
    roots = [n for n in names if n in script.initial_actors()]
    back = _back_edges(names, succ, roots)
    layer = dict.fromkeys(names, 0)
    # Longest path over what is left (a DAG): relax in rounds, at most one per actor.
    for _ in names:
        changed = False
        for src in names:
            for dst in succ[src]:
                if (src, dst) not in back and src != dst and layer[dst] < layer[src] + 1:
                    layer[dst] = layer[src] + 1
                    changed = True
        if not changed:
            break
    return layer, back


def _label(edge: Edge) -> str:
    """What the arrow says: the event, or the timeout's delay."""
    head = edge.label.split(" (")[0]
    return head if edge.kind == "branch" else head.replace("timeout ", "")


def _drawn_edges(edges: list[Edge]) -> list[_Drawn]:
    """One drawn edge per pair of actors: timeouts folded into their transition's edge, a
    branching transition labelled on its first edge only."""
    pairs: dict[tuple[str, str], _Drawn] = {}
    labelled: set[tuple[str, str]] = set()
    for e in sorted(edges, key=lambda e: e.kind == "timeout"):  # stable: branches first
        drawn = pairs.get((e.source, e.target))
        if drawn is None:
            fan = (e.source, _label(e))
            text = "" if fan in labelled else _label(e)
            labelled.add(fan)
            pairs[(e.source, e.target)] = _Drawn([e], text)
            continue
        drawn.edges.append(e)
        if e.kind == "branch" and _label(e) not in drawn.text.split(", "):
            drawn.text = ", ".join(t for t in (drawn.text, _label(e)) if t)
    return list(pairs.values())


def _order(ranks: list[list[_Box]]) -> None:
    """Barycentre sweeps: sort each rank by its neighbours' mean place in the rank before."""

    def sweep(rows: list[list[_Box]], side: str) -> None:
        for row in rows:
            place: dict[int, float] = {}
            for box in row:
                near = box.up if side == "up" else box.down
                if near:
                    place[id(box)] = sum(_index[id(n)] for n in near) / len(near)
                else:
                    place[id(box)] = _index[id(box)]
            row.sort(key=lambda b: place[id(b)])
            for i, box in enumerate(row):
                _index[id(box)] = float(i)

    _index: dict[int, float] = {}
    for row in ranks:
        for i, box in enumerate(row):
            _index[id(box)] = float(i)
    for _ in range(_SWEEPS):
        sweep(ranks[1:], "up")
        sweep(list(reversed(ranks[:-1])), "down")


def _place(ranks: list[list[_Box]]) -> None:
    """x of every box: packed, then pulled towards its neighbours, order and gaps kept."""
    for row in ranks:
        x = 0.0
        for box in row:
            box.x = x + box.w / 2
            x += box.w + GAP_X

    def settle(row: list[_Box], side: str) -> None:
        if not row:
            return
        wanted = []
        for box in row:
            near = box.up if side == "up" else box.down
            near = near or (box.down if side == "up" else box.up)
            wanted.append(sum(n.x for n in near) / len(near) if near else box.x)
        # Left to right at the wanted places, no closer than the gap; then the whole row
        # shifted so that it is off its wanted places as little on one side as the other.
        placed: list[float] = []
        for i, box in enumerate(row):
            x = wanted[i]
            if placed:
                prev = row[i - 1]
                x = max(x, placed[-1] + prev.w / 2 + GAP_X + box.w / 2)
            placed.append(x)
        shift = sum(w - p for w, p in zip(wanted, placed, strict=True)) / len(row)
        for box, x in zip(row, placed, strict=True):
            box.x = x + shift

    for _ in range(_SWEEPS):
        for row in ranks[1:]:
            settle(row, "up")
        for row in reversed(ranks[:-1]):
            settle(row, "down")


def layout(script: TaskScript) -> dict[str, Any]:
    """JSON-ready: ``nodes`` (name, x, y, w, h of the box, layer, initial platforms or
    ""), ``edges`` (source, target, label, event, kind, back; ``points``, the polyline to
    draw through, from the source's box to the target's; ``text``, the label shown, and
    ``box``, where it goes — x, y, w, h, or None without a label; ``title``, every label of
    the edges drawn as this one) and the drawing's ``width`` and ``height``. ``back``
    marks an edge that goes to the same or an earlier layer."""
    names = [a.name for a in script.actors]
    graph_edges = [e for e in state_edges(script) if e.source != START]
    layer, back = _layers(script, graph_edges)
    layers = max(layer.values(), default=0) + 1
    ranks: list[list[_Box]] = [[] for _ in range(2 * layers)]
    nodes: dict[str, _Box] = {}
    for n in names:
        box = _Box(n, 2 * layer[n], name_width(n), NODE_H, actor=n, core=name_width(n))
        nodes[n] = box
        ranks[box.rank].append(box)
    drawn = _drawn_edges(graph_edges)
    for d in drawn:
        e = d.edges[0]
        a, b = nodes[e.source], nodes[e.target]
        if a is b:
            # A loop: on the actor's right, with its label; room kept for both.
            a.w += LOOP_W + (label_width(d.text) if d.text else 0.0)
            d.boxes = [a]
            continue
        top, bottom = (b, a) if (e.source, e.target) in back or b.rank < a.rank else (a, b)
        chain = [top]
        last = bottom.rank - 1 if bottom.rank > top.rank else top.rank + 1
        for r in range(top.rank + 1, last + 1):
            first = r == top.rank + 1
            text = d.text if first else ""
            w = label_width(text) if text else PASS_W
            slot = _Box(f"{e.source}>{e.target}@{r}", r, w, LABEL_H if r % 2 else NODE_H)
            slot.text = text
            ranks[r].append(slot)
            chain.append(slot)
        chain.append(bottom)
        for one, two in pairwise(chain):
            # Within a layer the chain goes down to the slot and back up: link by rank.
            upper, lower = (one, two) if two.rank > one.rank else (two, one)
            upper.down.append(lower)
            lower.up.append(upper)
        d.boxes = chain if top is a else list(reversed(chain))
    _order(ranks)
    _place(ranks)
    # Heights and tops of the ranks; the drawing shifted right of the margin.
    tops: list[float] = []
    y = MARGIN + TOP
    for r, row in enumerate(ranks):
        tops.append(y)
        y += max((b.h for b in row), default=LABEL_H if r % 2 else NODE_H) + GAP_Y
    height = y - GAP_Y + MARGIN
    left = min((b.x - b.w / 2 for row in ranks for b in row), default=0.0)
    for row in ranks:
        for b in row:
            b.x += MARGIN - left
    width = max((b.x + b.w / 2 for row in ranks for b in row), default=0.0) + MARGIN

    def top_of(b: _Box) -> float:
        return tops[b.rank] + (NODE_H - b.h) / 2 if b.rank % 2 == 0 else tops[b.rank]

    out_nodes = []
    initial = script.initial_actors()
    for n in names:
        box = nodes[n]
        out_nodes.append(
            {
                "name": n,
                "x": round(box.x - box.w / 2, 1),
                "y": round(top_of(box), 1),
                "w": round(box.core, 1),
                "h": NODE_H,
                "layer": box.rank // 2,
                "initial": id_ranges(initial[n]) if n in initial else "",
            }
        )
    ports = _ports(drawn)
    out_edges = []
    for d in drawn:
        e = d.edges[0]
        a, b = nodes[e.source], nodes[e.target]
        points, label = _route(d, a, b, top_of, ports)
        out_edges.append(
            {
                "source": e.source,
                "target": e.target,
                "label": e.label,
                "event": e.label.split(" (")[0] if e.kind == "branch" else "",
                "kind": e.kind,
                "back": a is b or b.rank <= a.rank,
                "points": points,
                "text": d.text,
                "box": label,
                "title": "\n".join(x.label for x in d.edges),
            }
        )
    return {
        "nodes": out_nodes,
        "edges": out_edges,
        "width": round(width, 1),
        "height": round(height, 1),
    }


def _ports(drawn: list[_Drawn]) -> dict[tuple[int, int], float]:
    """Where each drawn edge meets each actor's box (keyed by the edge's and the box's
    ids): the edges on one side of an actor spread over the middle of that side, in the
    order of where they come from, so that many edges into one actor stay apart."""
    sides: dict[tuple[int, bool], list[tuple[float, int]]] = {}
    for d in drawn:
        boxes = d.boxes
        if len(boxes) < 2:
            continue
        for end, near in ((boxes[0], boxes[1]), (boxes[-1], boxes[-2])):
            sides.setdefault((id(end), near.rank > end.rank), []).append((near.x, id(d)))
    out: dict[tuple[int, int], float] = {}
    boxes_by_id = {id(b): b for d in drawn for b in d.boxes}
    for (box_id, _), comers in sides.items():
        box = boxes_by_id[box_id]
        comers.sort()
        centre = box.x - box.w / 2 + box.core / 2
        span = min(box.core * 0.6, 12.0 * (len(comers) - 1))
        for i, (_, edge_id) in enumerate(comers):
            at = 0.0 if len(comers) == 1 else -span / 2 + span * i / (len(comers) - 1)
            out[(edge_id, box_id)] = centre + at
    return out


def _route(
    d: _Drawn, a: _Box, b: _Box, top_of: Any, ports: dict[tuple[int, int], float]
) -> tuple[list[list[float]], dict[str, float] | None]:
    """The points of a drawn edge from ``a`` to ``b`` and its label's box."""
    label: dict[str, float] | None = None
    if a is b:
        x = a.x - a.w / 2 + a.core
        y = top_of(a)
        points = [[x, y + 7], [x + LOOP_W - 4, y + NODE_H / 2], [x, y + NODE_H - 7]]
        if d.text:
            w = label_width(d.text)
            label = {"x": x + LOOP_W - 2, "y": y + (NODE_H - LABEL_H) / 2, "w": w, "h": LABEL_H}
        return [[round(p, 1) for p in q] for q in points], label
    boxes = d.boxes
    points = []
    for i, box in enumerate(boxes):
        top = top_of(box)
        if box.actor:
            nxt = boxes[1] if i == 0 else boxes[i - 1]
            x = ports.get((id(d), id(box)), box.x - box.w / 2 + box.core / 2)
            points.append([x, top + NODE_H if nxt.rank > box.rank else top])
        else:
            points.append([box.x, top + box.h / 2])
            if box.text:
                label = {"x": box.x - box.w / 2, "y": top, "w": box.w, "h": box.h}
    label = None if label is None else {k: round(v, 1) for k, v in label.items()}
    return [[round(p, 1) for p in q] for q in points], label
