"""Exclusive hardware resources and who holds them (docs/design.md §5).

Theory of operation
-------------------
A platform's hardware — the autopilot, a camera, a gimbal — is named by strings, and each
name is held by at most one actor at a time. Actors whose resource sets are disjoint run side
by side; that is how one platform runs several actors.

:meth:`ResourceArbiter.acquire` grants an actor *all* the resources it needs or none:

- if every needed resource is free, it is granted;
- if some are held, and *every* holder in the way has a strictly lower priority, those holders
  are preempted: they lose everything they hold, and the caller must pause them
  (:attr:`Grant.preempted`);
- otherwise (one holder of equal or higher priority is enough) it raises
  :class:`ResourceBusy` and changes nothing — no holder is preempted for a grant that cannot
  happen.

A preempted actor is remembered with what it needs and its priority. Whenever resources come
free (a release, or the leftovers of a preempted holder), the waiting actors are scanned,
higher priority first and, among equals, in the order they were preempted; each one whose
needs are *all* free gets them back and is reported so that the runtime re-activates it.
Resuming never preempts anyone: an actor that wants to push its way back calls
:meth:`~ResourceArbiter.acquire` again. After every call no waiting actor could be resumed.

The arbiter knows nothing of actor states or time; the runtime calls ``release`` when an actor
stops (or gives its hardware up when it pauses). Every result is a deterministic function of
the calls made: resources are visited in sorted order.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

__all__ = ["Grant", "ResourceArbiter", "ResourceBusy"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Grant:
    """A successful :meth:`ResourceArbiter.acquire`.

    ``actor`` now holds ``resources``. The runtime must pause every actor in ``preempted``
    (they hold nothing any more) and re-activate every actor in ``resumed`` (preempted
    earlier, they got back what they need from resources the preempted freed), in order.
    """

    actor: str
    resources: frozenset[str]
    preempted: tuple[str, ...] = ()
    resumed: tuple[str, ...] = ()


class ResourceBusy(ValueError):
    """An actor asked for resources held by an actor of equal or higher priority. Nothing
    changed. ``resource``, ``holder`` and ``holder_priority`` name the first obstacle (in
    sorted resource order); ``blocking`` lists all of them as (resource, holder, priority)."""

    def __init__(
        self, actor: str, priority: int, blocking: tuple[tuple[str, str, int], ...]
    ) -> None:
        self.actor = actor
        self.priority = priority
        self.blocking = blocking
        self.resource, self.holder, self.holder_priority = blocking[0]
        others = "".join(
            f"; {res!r} is also held by {who!r} at priority {prio}"
            for res, who, prio in blocking[1:]
        )
        super().__init__(
            f"actor {actor!r} (priority {priority}) cannot have {self.resource!r}: actor "
            f"{self.holder!r} holds it at priority {self.holder_priority}, and only a strictly "
            f"lower priority can be preempted{others}. Stop or pause {self.holder!r} first, or "
            f"give {actor!r} a priority above {max(p for _, _, p in blocking)}"
        )


@dataclass(frozen=True, slots=True)
class _Waiting:
    """A preempted actor: what it needs back, its priority, and when it was preempted."""

    needs: frozenset[str]
    priority: int
    order: int


class ResourceArbiter:
    """Grants exclusive resources to actors by priority; see the module docstring."""

    def __init__(self) -> None:
        self._holder: dict[str, str] = {}  # resource -> actor
        self._held: dict[str, tuple[int, frozenset[str]]] = {}  # actor -> (priority, set)
        self._waiting: dict[str, _Waiting] = {}  # preempted actor -> what it waits for
        self._preemptions = 0  # numbers preemptions, for the resume order among equals

    def acquire(self, actor: str, priority: int, resources: Iterable[str]) -> Grant:
        """Give ``actor`` (at ``priority``, larger is higher) every resource in
        ``resources``, preempting strictly lower-priority holders if that makes all of them
        available.

        Raises :class:`ResourceBusy` (nothing changed) when a needed resource is held at an
        equal or higher priority, ValueError when ``actor`` already holds resources (it
        must release them first), and TypeError for a bare string instead of a set.

        An actor that is waiting after a preemption may call this to compete again; when
        granted, it stops waiting. An empty set is granted and not recorded.
        """
        if isinstance(resources, str):
            # A bare string would be read as a set of one-letter resources.
            raise TypeError(f"actor {actor!r}: pass resources as a set of names, not a string")
        needs = frozenset(resources)
        if not actor:
            raise ValueError("acquire needs an actor name")
        if "" in needs:
            raise ValueError(f"actor {actor!r}: resource names must be non-empty")
        if actor in self._held:
            raise ValueError(
                f"actor {actor!r} already holds {_names(self._held[actor][1])}; release them "
                "before acquiring again"
            )
        in_the_way: list[str] = []
        blocking: list[tuple[str, str, int]] = []
        for resource in sorted(needs):
            holder = self._holder.get(resource)
            if holder is None:
                continue
            holder_priority = self._held[holder][0]
            if holder_priority >= priority:
                blocking.append((resource, holder, holder_priority))
            elif holder not in in_the_way:
                in_the_way.append(holder)
        if blocking:
            raise ResourceBusy(actor, priority, tuple(blocking))

        for holder in in_the_way:
            holder_priority, held = self._take_away(holder)
            self._waiting[holder] = _Waiting(held, holder_priority, self._preemptions)
            self._preemptions += 1
        self._waiting.pop(actor, None)
        if needs:
            self._give(actor, priority, needs)
        resumed = self._resume() if in_the_way else []
        return Grant(
            actor=actor, resources=needs, preempted=tuple(in_the_way), resumed=tuple(resumed)
        )

    def release(self, actor: str) -> list[str]:
        """``actor`` gives up everything it holds and stops waiting for anything.

        Returns the preempted actors that got all they need back, in the order to re-activate
        them (higher priority first, then preemption order); they hold their resources
        again when this returns. Releasing an actor that holds nothing is harmless.
        """
        self._waiting.pop(actor, None)
        if actor not in self._held:
            return []
        self._take_away(actor)
        return self._resume()

    def holders(self) -> dict[str, str]:
        """Every held resource and the actor holding it, in sorted resource order."""
        return {resource: self._holder[resource] for resource in sorted(self._holder)}

    def held_by(self, actor: str) -> frozenset[str]:
        """The resources ``actor`` holds (empty if none)."""
        return self._held.get(actor, (0, frozenset()))[1]

    def waiting(self) -> dict[str, frozenset[str]]:
        """The preempted actors and what each needs back, in the order they were preempted."""
        return {actor: w.needs for actor, w in self._waiting.items()}

    def _give(self, actor: str, priority: int, needs: frozenset[str]) -> None:
        self._held[actor] = (priority, needs)
        for resource in needs:
            self._holder[resource] = actor

    def _take_away(self, actor: str) -> tuple[int, frozenset[str]]:
        priority, held = self._held.pop(actor)
        for resource in held:
            del self._holder[resource]
        return priority, held

    def _resume(self) -> list[str]:
        # One pass suffices: resuming only takes resources, so an actor that could not
        # resume earlier in the pass cannot resume later in it either.
        resumed: list[str] = []
        for actor, w in sorted(self._waiting.items(), key=lambda i: (-i[1].priority, i[1].order)):
            if not any(resource in self._holder for resource in w.needs):
                del self._waiting[actor]
                self._give(actor, w.priority, w.needs)
                resumed.append(actor)
        return resumed


def _names(resources: Iterable[str]) -> str:
    return ", ".join(repr(r) for r in sorted(resources)) or "nothing"
