"""What the barrier parts share (see :mod:`actorswarm.core.barrier`): the limits of what a
master remembers, the hooks the task engine plugs in, the records of open generations,
firings and releases in flight, and :class:`BarrierOutput`, where the master's parts put
what they decide.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeVar

from actorswarm.core.events import BarrierFired
from actorswarm.core.wire import (
    COMPLETE,
    TIMEOUT,
    BarrierRequest,
    BarrierStale,
    Release,
    ReleaseEntry,
)

_K = TypeVar("_K")

OUTCOME_NAMES = {COMPLETE: "complete", TIMEOUT: "timeout"}
#: How many past generations a master remembers per key, and members report: a partition
#: whose other side fired more generations than this cannot be reconciled exactly.
RECENT_RELEASES = 32
#: Of those, how many carry their whole assignment in a report (bounds the report's size).
RECENT_ASSIGNMENTS = 4
#: A firing of more candidates than this is reported whole by its lowest few IDs only
#: (:data:`ASSIGNMENT_CARRIERS`): every member's report repeating the whole assignment made
#: a new master's handshake O(N²) bytes (a kilobyte per member at 200).
ASSIGNMENT_ALL_CARRY = 16
#: How many of a large firing's candidates, the lowest IDs, keep its whole assignment. The
#: lowest IDs are the master's successors: a new master that took part carries it itself.
ASSIGNMENT_CARRIERS = 4

#: Resolves the need ``count`` (a number, or NEED_ALL) of (key, part) to the number of
#: candidates the part waits for now; 0: the part cannot have candidates and does not hold
#: the barrier back (default: ``count``, and every live platform for NEED_ALL).
NeedResolver = Callable[[int, int, int], int]
#: Computes per-participant scatter data: (key, generation, chosen) -> {platform: data}.
Scatter = Callable[[int, int, list[tuple[int, int, int, BarrierRequest]]], dict[int, Any]]
#: Whether a release of barrier ``key`` carries every chosen participant's request data to
#: all of them (``gathered``), or leaves it to the master's :data:`Scatter` alone.
Gathers = Callable[[int], bool]


class BarrierOutput(Protocol):
    """Where the master's parts put what they decide, given to them at construction (the
    node routes it: to this platform's own member part, over a stream, or as a broadcast)."""

    def fired(self, event: BarrierFired) -> None:
        """A firing was decided (or a predecessor's completed)."""

    def stale(self, platform: int, notice: BarrierStale) -> None:
        """Tell ``platform`` its request is stale."""

    def release(self, packet: Release) -> None:
        """Broadcast ``packet``, one chunk of a release (its first sending or a retry)."""

    def gave_up(self, key: int, generation: int, unacked: set[int]) -> None:
        """A release of ``key``/``generation`` missed its deadline: ``unacked`` never
        acknowledged it."""


def bid_order(item: tuple[int, BarrierRequest]) -> tuple[float, int]:
    """Candidates in the order a firing chooses them: lower bid, then lower platform ID."""
    return (item[1].bid, item[0])


@dataclass(slots=True)
class OpenGeneration:
    """The open generation of a key: the requests waiting for it and since when.

    ``requests`` is read freely but changed only through :meth:`put` and :meth:`drop`, which
    keep the tallies the master consults on every request and every packet: how many
    candidates each part has, which (part, need) pairs the requests name, and the shortest
    timeout. Recounting them from ``requests`` each time made a switch of N platforms cost
    the master O(N²) (minutes at 10 000)."""

    generation: int
    requests: dict[int, BarrierRequest] = field(default_factory=dict)
    first_at: float | None = None
    #: Candidates per part.
    parts: dict[int, int] = field(default_factory=dict)
    #: How many requests name each (part, need count) pair.
    pairs: dict[tuple[int, int], int] = field(default_factory=dict)
    _timeout: float | None = None
    _timeout_known: bool = True

    def put(self, platform: int, req: BarrierRequest) -> None:
        """``platform``'s request, replacing any earlier one of it."""
        self.drop(platform)
        self.requests[platform] = req
        self.parts[req.part] = self.parts.get(req.part, 0) + 1
        for pair in req.need.items():
            self.pairs[pair] = self.pairs.get(pair, 0) + 1
        if req.timeout is not None and self._timeout_known:
            known = self._timeout
            self._timeout = req.timeout if known is None else min(known, req.timeout)

    def drop(self, platform: int) -> None:
        """Forget ``platform``'s request, if any."""
        req = self.requests.pop(platform, None)
        if req is None:
            return
        _decrement(self.parts, req.part)
        for pair in req.need.items():
            _decrement(self.pairs, pair)
        if req.timeout is not None:
            self._timeout_known = False  # recomputed when next asked

    def timeout(self) -> float | None:
        """The shortest timeout of the requests (None: none has one)."""
        if not self._timeout_known:
            timeouts = [r.timeout for r in self.requests.values() if r.timeout is not None]
            self._timeout = min(timeouts) if timeouts else None
            self._timeout_known = True
        return self._timeout


def _decrement(counts: dict[_K, int], key: _K) -> None:
    left = counts[key] - 1
    if left:
        counts[key] = left
    else:
        del counts[key]


@dataclass(slots=True)
class Firing:
    """What the master knows of the last firing of a key (for completions and late repeats)."""

    generation: int
    origin: int  # epoch of the master that decided it
    master: int  # ID of that master: two partitions' masters may claim one epoch number
    outcome: int
    sizes: dict[int, int]
    assigned: dict[int, tuple[int, int]]  # platform -> (part, index); index 0 = not chosen
    complete_knowledge: bool  # False when rebuilt from member reports after a failover
    occasions: frozenset[str] = frozenset()  # what the firing's requests were made for
    entries: dict[int, ReleaseEntry] = field(default_factory=dict)
    gathered: list[tuple[int, Any]] = field(default_factory=list)


@dataclass(slots=True)
class OutgoingRelease:
    """A release in flight: retransmitted to ``unacked`` until they acknowledge or leave."""

    key: int
    generation: int
    origin: int
    master: int
    epoch: int
    outcome: int
    sizes: dict[int, int]
    entries: dict[int, ReleaseEntry]
    gathered: list[tuple[int, Any]]
    unacked: set[int]
    deadline: float
    retries: int = 0
    due: float = 0.0
    #: ``entries`` are the whole firing. A firing rebuilt from reports after a failover holds
    #: only the entries it resent: a member that found them all in one packet would take
    #: them for the whole assignment, report it, and a later master would refuse a
    #: candidate it does not name as stale (campaign seed 2009944).
    whole: bool = True

    def packets(self, only: Iterable[int] | None, chunk: int) -> list[Release]:
        """The release as broadcast packets of at most ``chunk`` entries each."""
        targets = sorted(self.entries) if only is None else sorted(only)
        out = []
        for start in range(0, max(len(targets), 1), chunk):
            part = targets[start : start + chunk]
            out.append(
                Release(
                    epoch=self.epoch,
                    key=self.key,
                    generation=self.generation,
                    outcome=self.outcome,
                    sizes=self.sizes,
                    entries=[self.entries[p] for p in part],
                    gathered=self.gathered,
                    origin=self.origin,
                    total=len(self.entries) if self.whole else 0,
                    origin_master=self.master,
                )
            )
        return out


def addressee(rel: Release, master: int) -> int | None:
    """Where a release packet goes: to its one candidate besides the master when it names
    only one (a barrier of one platform, or a retransmission to the last member that has not
    acknowledged), else to everyone.

    Every other member would wake for such a packet only to learn that the generation fired
    (:meth:`~actorswarm.core.barrier.member.BarrierMember.on_release`); what not learning it
    costs is a stale notice on its next request of the key, and the engine asks again. With
    every one of 31 daemons switching by a barrier of one every second, the overheard
    releases were more than half of what each member received, and on Zenoh's mesh a
    broadcast is one copy per peer (docs/benchmarks/README.md, "Releases of one")."""
    if len(rel.entries) > 2:  # the entries name distinct platforms
        return None
    others = [e.platform for e in rel.entries if e.platform != master]
    return others[0] if len(others) == 1 else None


__all__ = [
    "ASSIGNMENT_ALL_CARRY",
    "ASSIGNMENT_CARRIERS",
    "OUTCOME_NAMES",
    "RECENT_ASSIGNMENTS",
    "RECENT_RELEASES",
    "BarrierOutput",
    "Firing",
    "Gathers",
    "NeedResolver",
    "OpenGeneration",
    "OutgoingRelease",
    "Scatter",
    "addressee",
    "bid_order",
]
