"""What a transition group waits for, decided by the master (docs/task-scripts.md, "What a
group waits for").

A group is the transitions that share one ``barrierKey``; each is a *part* of one core
barrier. The master fires the group when every part that can have candidates has its
``sysNum`` of them:

* ``sysNum="all"``: every live platform that runs the part's actor in the master's view (a
  member that has not said what it runs yet counts, so the group waits rather than fires
  short). No holder: the part waits for nobody and holds the group back from nothing.
* a number ``n``: ``n`` candidates, unless no live platform runs the part's actor or an actor
  from which the script's transitions can still lead to it: nobody ever will, and the part
  holds nothing back either (it would otherwise wait for its timeout, or for ever).

The need is recomputed whenever the master learns that a platform entered or left an actor,
joined or left, so a group whose last holder of a part is lost or switches away fires
without it. A platform that *enters* a part's actor while its group waits counts as a holder
at once; when the event the group waits on was shared (relayed to the swarm, or sent by the
operator), the master forwards it that event, so it becomes a candidate like the others.
A platform's own local events (a plugin's, scope ``local``) are never forwarded: the
newcomer raises its own.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from actorswarm.core.wire import NEED_ALL
from actorswarm.dsl.model import TaskScript, Transition

#: How many shared events (relayed or the operator's) a platform remembers for forwarding.
SHARED_MEMORY = 64


def reaching(script: TaskScript) -> dict[str, frozenset[str]]:
    """For each actor, the actors from which the script's transitions (any branch or
    timeout branch, over any number of switches) lead to it, itself included."""
    edges: dict[str, set[str]] = {a.name: set() for a in script.actors}
    for actor, transitions in script.transitions.items():
        for t in transitions:
            targets = {b.successor for b in t.branches}
            if t.timeout_branch is not None:
                targets.add(t.timeout_branch)
            edges.setdefault(actor, set()).update(targets)
    into: dict[str, set[str]] = {a: set() for a in edges}
    for src, dsts in edges.items():
        for dst in dsts:
            into.setdefault(dst, set()).add(src)
    out: dict[str, frozenset[str]] = {}
    for actor in into:
        seen = {actor}
        todo = [actor]
        while todo:
            for src in into.get(todo.pop(), ()):
                if src not in seen:
                    seen.add(src)
                    todo.append(src)
        out[actor] = frozenset(seen)
    return out


def part_need(
    transition: Transition,
    count: int,
    table: Mapping[int, tuple[str, ...]],
    live: Iterable[int],
    reach: Mapping[str, frozenset[str]],
) -> int:
    """The candidates part ``transition`` (need ``count``: a number or NEED_ALL) waits for,
    given who runs what (``table``; a live platform missing from it may run anything)."""
    actor = transition.actor
    holders = 0
    reachable = False
    sources = reach.get(actor, frozenset((actor,)))
    for p in live:
        running = table.get(p)
        if running is None or actor in running:
            holders += 1
            reachable = True
        elif not reachable and not sources.isdisjoint(running):
            reachable = True
    if count == NEED_ALL:
        return holders
    return count if reachable else 0


class SharedEvents:
    """The latest shared events this platform heard (relayed to the swarm or sent by the
    operator), by occasion: what a master forwards to a platform that enters an actor while
    a group of that actor waits on one of them, or that comes back running an actor the
    swarm has left on one of them."""

    def __init__(self, size: int = SHARED_MEMORY) -> None:
        self._size = size
        self._by_occasion: dict[str, tuple[str, int, Any]] = {}

    def remember(self, occasion: str, event: str, origin: int, data: Any) -> None:
        if not occasion:
            return
        self._by_occasion.pop(occasion, None)
        self._by_occasion[occasion] = (event, origin, data)
        while len(self._by_occasion) > self._size:
            del self._by_occasion[next(iter(self._by_occasion))]

    def get(self, occasion: str) -> tuple[str, int, Any] | None:
        """``(event, origin, data)`` of ``occasion``, or None when it was not shared (or is
        forgotten)."""
        return self._by_occasion.get(occasion)

    def newest_first(self) -> list[tuple[str, str, int, Any]]:
        """``(occasion, event, origin, data)`` of every event kept, the latest heard first."""
        return [(occasion, *kept) for occasion, kept in reversed(self._by_occasion.items())]


__all__ = ["SHARED_MEMORY", "SharedEvents", "part_need", "reaching"]
