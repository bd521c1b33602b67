"""The master's barrier table and the releases in flight (see :mod:`actorswarm.core.barrier`).

The state every part of the master's side shares: the open generation of each key, the
firings it knows, the releases it retransmits, and what the node drains. The decisions live
in :mod:`~actorswarm.core.barrier_master` (requests, firing, time) and
:mod:`~actorswarm.core.barrier_completion` (late requests and failover completion).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from actorswarm.core.config import CoreConfig
from actorswarm.core.events import BarrierFired
from actorswarm.core.wire import (
    COMPLETE,
    TIMEOUT,
    BarrierRequest,
    BarrierStale,
    Release,
    ReleaseEntry,
    ReleaseRecord,
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


class MasterState:
    """The master's barrier table; decisions are made by the subclasses."""

    def __init__(
        self,
        config: CoreConfig,
        *,
        resolve_need: NeedResolver,
        scatter: Scatter | None = None,
        platform: int = 0,
    ) -> None:
        self._config = config
        #: This master's ID: with the epoch, the name of the firings it decides.
        self.platform = platform
        self._resolve_need = resolve_need
        #: First retransmission delay of a release (the node plugs in its measured RTT).
        self.first_retry: Callable[[], float] = lambda: config.retry_base
        #: The wait before a release's next retransmission after k, from the first
        #: (the node plugs in its reliable layer's, which paces a shared channel).
        #: Called with the retries so far, the first retry's delay and how many members the
        #: retransmission asks to acknowledge.
        self.retry_delay: Callable[[int, float, int], float] = lambda k, first, answers: (
            config.retry_delay(k, first)
        )
        self.scatter = scatter
        #: Whether a platform is in the master's view (itself included). A part that waits
        #: for every platform (NEED_ALL) counts only their requests: one from beyond the view
        #: (a platform still joining, or one the master dropped) must not stand in for a
        #: member's. Default: everyone (a table without a view, as in unit tests).
        self.live: Callable[[int], bool] = lambda platform: True
        #: Gather by default; a key whose data only ``scatter`` reads says no, and its
        #: release chunks stay O(release_chunk) bytes rather than O(N) each.
        self.gathers: Gathers = lambda key: True
        self.open: dict[int, OpenGeneration] = {}
        # Known firings per key and generation (a generation may have two: partitions that
        # each fired it). Only the last few generations are kept.
        self.fired: dict[int, dict[int, list[Firing]]] = {}
        self.inflight: dict[tuple[int, int, int, int], OutgoingRelease] = {}
        self.ready = False
        #: (platform, notice) stale notices to send; drained by the node.
        self.notices: list[tuple[int, BarrierStale]] = []
        #: releases to broadcast now; drained by the node.
        self.broadcasts: list[Release] = []
        self.events: list[BarrierFired] = []
        self.failed: list[tuple[int, int, set[int]]] = []
        # Requests for a generation a previous master fired, waiting to be completed.
        self._completion_waiting: dict[int, dict[int, BarrierRequest]] = {}
        # The newest open generation members reported per key.
        self._known: dict[int, int] = {}
        # Requests refused while reports may still be on their way (see _refuse).
        self._doubtful: dict[tuple[int, int], BarrierRequest] = {}
        self._hold_fire = False
        # Keys that do not fire before a time (hold), whatever requests they have.
        self._holds: dict[int, float] = {}
        self._changed_at = -float("inf")
        # Requests received during the handshake, with their arrival time.
        self._staged: dict[tuple[int, int], tuple[BarrierRequest, float]] = {}
        # Requests older than every firing known of their generation, with how long they
        # wait for a report of the firing that may have chosen them (see _late_request).
        self._parked: dict[tuple[int, int], tuple[BarrierRequest, float]] = {}

    def _instance(self, key: int) -> OpenGeneration:
        inst = self.open.get(key)
        if inst is None:
            gens = self.fired.get(key)
            inst = self.open[key] = OpenGeneration(max(gens) + 1 if gens else 0)
        return inst

    def _launch(self, key: int, fired: Firing, targets: set[int], now: float, epoch: int) -> None:
        ident = (key, fired.generation, fired.origin, fired.master)
        rel = self.inflight.get(ident)
        if rel is None:
            rel = OutgoingRelease(
                key=key,
                generation=fired.generation,
                origin=fired.origin,
                master=fired.master,
                epoch=epoch,
                outcome=fired.outcome,
                sizes=fired.sizes,
                entries=fired.entries,
                gathered=fired.gathered,
                unacked=set(),
                deadline=now + self._config.delivery_deadline,
            )
            self.inflight[ident] = rel
        rel.epoch = epoch
        rel.whole = fired.complete_knowledge and fired.entries.keys() == fired.assigned.keys()
        rel.unacked |= targets
        rel.due = now + self.retry_delay(0, self.first_retry(), len(rel.unacked))
        self.broadcasts.extend(rel.packets(targets, self._config.release_chunk))

    def _resend(self, key: int, fired: Firing, platform: int, now: float, epoch: int) -> None:
        if platform not in fired.entries:
            part, index = fired.assigned[platform]
            fired.entries[platform] = ReleaseEntry(platform=platform, part=part, index=index)
        self._launch(key, fired, {platform}, now, epoch)

    def _prune(self, key: int, keep: int = RECENT_RELEASES) -> None:
        gens = self.fired.get(key, {})
        for old in sorted(gens)[:-keep]:
            del gens[old]

    def _prune_inflight(self) -> None:
        for k in [k for k, r in self.inflight.items() if not r.unacked]:
            del self.inflight[k]

    @staticmethod
    def _free_slot(fired: Firing, part: int) -> int | None:
        """An index of ``part`` nobody holds in ``fired``; a timeout firing grows instead
        (everyone waiting passes a timeout)."""
        used = {i for (p, i) in fired.assigned.values() if p == part and i > 0}
        size = fired.sizes.get(part, 0)
        for index in range(1, size + 1):
            if index not in used:
                return index
        if fired.outcome == TIMEOUT:
            fired.sizes[part] = size + 1
            return size + 1
        return None

    def decided(self, platform: int) -> list[ReleaseRecord]:
        """The firings this master decided or knows in full, as records for a report to its
        successor: a master that steps down right after a firing may be the only one that
        knows it (its release may not have reached anyone yet), and without this record its
        successor could fire the generation again without the first firing's candidates.

        A predecessor's firing this master completed goes as a *partial* assignment (the
        candidates it knows, those it added among them): its successor may know that
        firing whole as it was first decided, from a member's report, and would refuse a
        candidate the completion added, whose release was lost, as late."""
        out = []
        for key, gens in self.fired.items():
            for generation in sorted(gens)[-RECENT_ASSIGNMENTS:]:
                for fired in gens[generation]:
                    whole = fired.complete_knowledge
                    if not fired.assigned or not (whole or fired.entries):
                        continue
                    part, index = fired.assigned.get(platform, (min(fired.sizes, default=0), 0))
                    known = dict(fired.assigned)
                    out.append(
                        ReleaseRecord(
                            key=key,
                            generation=generation,
                            part=part,
                            index=index,
                            size=fired.sizes.get(part, 0),
                            outcome=fired.outcome,
                            origin=fired.origin,
                            assignment=known if whole else {},
                            origin_master=fired.master,
                            partial={} if whole else known,
                        )
                    )
        return out

    def request(self, platform: int, req: BarrierRequest, now: float, epoch: int) -> None:
        """A member's request (:class:`~actorswarm.core.barrier_master.BarrierMaster`)."""
        raise NotImplementedError

    def try_fire(self, key: int, now: float, epoch: int) -> None:
        """Fire ``key`` if its open generation can fire now
        (:class:`~actorswarm.core.barrier_master.BarrierMaster`)."""
        raise NotImplementedError


def addressee(rel: Release, master: int) -> int | None:
    """Where a release packet goes: to its one candidate besides the master when it names
    only one (a barrier of one platform, or a retransmission to the last member that has not
    acknowledged), else to everyone.

    Every other member would wake for such a packet only to learn that the generation fired
    (:meth:`~actorswarm.core.barrier_member.BarrierMember.on_release`); what not learning it
    costs is a stale notice on its next request of the key, and the engine asks again. With
    every one of 31 daemons switching by a barrier of one every second, the overheard
    releases were more than half of what each member received, and on Zenoh's mesh a
    broadcast is one copy per peer (docs/benchmarks/README.md, "Releases of one")."""
    if len(rel.entries) > 2:  # the entries name distinct platforms
        return None
    others = [e.platform for e in rel.entries if e.platform != master]
    return others[0] if len(others) == 1 else None


__all__ = [
    "OUTCOME_NAMES",
    "RECENT_ASSIGNMENTS",
    "RECENT_RELEASES",
    "Firing",
    "Gathers",
    "MasterState",
    "NeedResolver",
    "OpenGeneration",
    "OutgoingRelease",
    "Scatter",
    "addressee",
    "bid_order",
]
