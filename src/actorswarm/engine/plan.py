"""A task script compiled for the engine: barrier groups, parts and branch filling.

Theory of operation
-------------------
Every transition belongs to one *group*, the unit the collective core synchronizes: the
transitions that share a ``barrierKey`` form one group (they fire on one release), and a
transition without a key is a group of its own. A group maps to one core barrier key (the
script's key, or ``1000 + n`` for the n-th keyless transition), and each of its transitions
is one *part* of that barrier, needing ``sysNum`` participants (or ``NEED_ALL``: every holder
of the transition's actor in the master's view).

When the master fires a group it numbers each part's chosen participants 1..n in bid order;
:meth:`Plan.successor` fills the transition's branches in that order — integer counts first,
as written, then the ``rest`` branch — so the index a participant receives decides where it
goes, on the master and on any later master that completes the firing.
"""

from __future__ import annotations

from dataclasses import dataclass

from actorswarm.core.wire import NEED_ALL
from actorswarm.dsl.model import TaskScript, Transition
from actorswarm.engine.groups import reaching

#: Core barrier keys of keyless transitions start here (script keys are 1..63).
KEYLESS_BASE = 1000


@dataclass(frozen=True, slots=True)
class Group:
    """Transitions that fire together on one release of core barrier ``key``."""

    key: int
    parts: tuple[Transition, ...]

    def need(self) -> dict[int, int]:
        """Participants each part needs (``NEED_ALL`` for ``sysNum="all"``)."""
        return {
            i: (NEED_ALL if t.sys_num == "all" else int(t.sys_num))
            for i, t in enumerate(self.parts)
        }

    @property
    def timeout(self) -> float | None:
        """The group's timeout: the shortest of its transitions'."""
        timeouts = [t.timeout for t in self.parts if t.timeout is not None]
        return min(timeouts) if timeouts else None


@dataclass(frozen=True, slots=True)
class Plan:
    """Lookups the engine needs, computed once per script."""

    script: TaskScript
    groups: dict[int, Group]
    by_event: dict[tuple[str, str], tuple[int, int]]  # (actor, event) -> (key, part)
    #: For each actor, the actors the script's transitions lead to it from (itself included):
    #: :func:`~actorswarm.engine.groups.reaching`.
    reach: dict[str, frozenset[str]]

    @classmethod
    def build(cls, script: TaskScript) -> Plan:
        keyed: dict[int, list[Transition]] = {}
        keyless: list[Transition] = []
        for actor in script.actors:
            for t in script.transitions.get(actor.name, ()):
                if t.barrier_key is None:
                    keyless.append(t)
                else:
                    keyed.setdefault(t.barrier_key, []).append(t)
        groups = {k: Group(k, tuple(ts)) for k, ts in keyed.items()}
        for n, t in enumerate(keyless):
            groups[KEYLESS_BASE + n] = Group(KEYLESS_BASE + n, (t,))
        by_event: dict[tuple[str, str], tuple[int, int]] = {}
        for key, group in groups.items():
            for part, t in enumerate(group.parts):
                by_event[(t.actor, t.event)] = (key, part)
        return cls(script, groups, by_event, reaching(script))

    def transition(self, key: int, part: int) -> Transition | None:
        group = self.groups.get(key)
        if group is None or not 0 <= part < len(group.parts):
            return None
        return group.parts[part]

    def events_of(self, actor: str) -> set[str]:
        return {e for (a, e) in self.by_event if a == actor}

    @staticmethod
    def successor(transition: Transition, index: int) -> str:
        """Where the participant numbered ``index`` (1-based, bid order) goes."""
        seen = 0
        rest: str | None = None
        for branch in transition.branches:
            if branch.count == "rest":
                rest = branch.successor
                continue
            seen += int(branch.count)
            if index <= seen:
                return branch.successor
        if rest is not None:
            return rest
        # More participants than the counts (sysNum="all" grew): the last branch takes them.
        return transition.branches[-1].successor

    @staticmethod
    def placement(transition: Transition, index: int, size: int) -> tuple[int, int]:
        """``(slot, slots)`` of the participant numbered ``index`` of ``size`` chosen: its
        1-based place among those :meth:`successor` sends to the same branch, and how many
        it sends there. Counted branches fill first, in script order, then ``rest``; when
        more were chosen than the counts (``sysNum="all"`` grew) the last branch takes the
        extra ones, as :meth:`successor` does."""
        if index < 1:
            return 0, 0
        size = max(size, index)
        counted = [b for b in transition.branches if b.count != "rest"]
        has_rest = len(counted) < len(transition.branches)
        before = 0
        for k, branch in enumerate(counted):
            count = int(branch.count)
            last = k == len(counted) - 1 and not has_rest
            if index <= before + count or last:
                slots = size - before if last else min(count, size - before)
                return index - before, slots
            before += count
        return index - before, size - before

    def initial_actors(self, platform: int) -> list[str]:
        """The actors ``platform`` starts, in script order."""
        return [line.actor for line in self.script.platforms if platform in line.ids]
