"""Barriers with gather/scatter, master side and member side (docs/design.md §3.4).

Theory of operation
-------------------
A barrier instance is a key plus a *generation*. A member asks to pass with a
:class:`~actorswarm.core.wire.BarrierRequest` for the generation it believes is open
(``known[key]``, the number of firings it has seen). The master keeps the open generation per
key; a request for an older one is refused with a stale notice (requests of an old generation
never count for a new one), a newer one moves the master forward.

A key may have several *parts* (the task engine maps a group of transitions that share a key
to parts); each part needs a number of participants. When every part has enough requests, the
master chooses the best bids of each part (lower bid first, then lower platform ID), numbers
them 1..n within their part, and releases everyone — chosen and not chosen — with **one**
broadcast :class:`~actorswarm.core.wire.Release`. It retransmits the release only to the
candidates that have not acknowledged, with only their entries, so master traffic grows
linearly with the swarm. A member passes each (key, generation) at most once.

Failover without losing state: a member reports its known generations, its pending request
and the last release it passed. A new master that learns from such reports that a generation
was already fired (some members passed it, others still wait for it) *completes* that firing:
the waiting candidates get the indices nobody reported, so every participant is released by
the same generation and none is released twice — the all-or-nothing property survives a
master crash in the middle of a release.

A timeout (seconds from the group's first request) releases every waiting candidate with
outcome ``timeout``.

A *hold* (:meth:`BarrierMaster.hold`) keeps a key from firing until a given time while its
requests gather, so that the best bids win rather than the first to arrive: a ``need`` of 1
would otherwise fire on the first request, whatever the bids of those still on their way.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import msgspec

from actorswarm.core.config import CoreConfig
from actorswarm.core.events import BarrierFired, BarrierReleased, BarrierStaleNotice
from actorswarm.core.wire import (
    COMPLETE,
    NEED_ALL,
    TIMEOUT,
    BarrierRequest,
    BarrierStale,
    Release,
    ReleaseEntry,
    ReleaseRecord,
)

OUTCOME_NAMES = {COMPLETE: "complete", TIMEOUT: "timeout"}
#: How many past generations a master remembers per key, and members report: a partition
#: whose other side fired more generations than this cannot be reconciled exactly.
RECENT_RELEASES = 32
#: Of those, how many carry their whole assignment in a report (bounds the report's size).
RECENT_ASSIGNMENTS = 4

#: Resolves a need of NEED_ALL for (key, part) to a count (default: live platforms).
AllResolver = Callable[[int, int], int]
#: Computes per-participant scatter data: (key, generation, chosen) -> {platform: data}.
Scatter = Callable[[int, int, list[tuple[int, int, int, BarrierRequest]]], dict[int, Any]]


def _order(item: tuple[int, BarrierRequest]) -> tuple[float, int]:
    return (item[1].bid, item[0])


@dataclass(slots=True)
class _Instance:
    generation: int
    requests: dict[int, BarrierRequest] = field(default_factory=dict)
    first_at: float | None = None


@dataclass(slots=True)
class _Fired:
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
                    total=len(self.entries),
                    origin_master=self.master,
                )
            )
        return out


class BarrierMaster:
    """The master's side: collects requests, decides firings, tracks releases in flight.

    ``ready`` is False during the handshake: requests are collected but nothing fires until
    every member has reported, so a new master never fires a generation its predecessor
    already fired.
    """

    def __init__(
        self,
        config: CoreConfig,
        *,
        resolve_all: AllResolver,
        scatter: Scatter | None = None,
        platform: int = 0,
    ) -> None:
        self._config = config
        #: This master's ID: with the epoch, the name of the firings it decides.
        self.platform = platform
        self._resolve_all = resolve_all
        #: First retransmission delay of a release (the node plugs in its measured RTT).
        self.first_retry: Callable[[], float] = lambda: config.retry_base
        self.scatter = scatter
        self.open: dict[int, _Instance] = {}
        # Known firings per key and generation (a generation may have two: partitions that
        # each fired it). Only the last few generations are kept.
        self.fired: dict[int, dict[int, list[_Fired]]] = {}
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

    def _instance(self, key: int) -> _Instance:
        inst = self.open.get(key)
        if inst is None:
            gens = self.fired.get(key)
            inst = self.open[key] = _Instance(max(gens) + 1 if gens else 0)
        return inst

    # --- inputs ------------------------------------------------------------------------

    def request(self, platform: int, req: BarrierRequest, now: float, epoch: int) -> None:
        """A member's request (or its re-statement in a handshake report).

        During the handshake requests are only staged: until every report is in, the master
        cannot tell a stale request from one that belongs to a firing to complete.
        """
        if not self.ready:
            self._staged[(platform, req.key)] = (req, now)
            return
        firings = self.fired.get(req.key, {}).get(req.generation)
        if firings:
            self._late_request(platform, req, firings, now, epoch)
            return
        inst = self._instance(req.key)
        if req.generation < inst.generation:
            self._refuse(platform, req, inst.generation, now, epoch)
            return
        if req.generation > inst.generation:
            # The member saw a firing this master does not know of (a predecessor's):
            # move on; whoever waited on the old generation is refused.
            for other, old in inst.requests.items():
                self._refuse(other, old, req.generation, now, epoch)
            inst = self.open[req.key] = _Instance(req.generation)
        inst.requests[platform] = req
        start = now - req.age
        if inst.first_at is None or start < inst.first_at:
            inst.first_at = start
        if self.ready and not self._hold_fire:
            self.try_fire(req.key, now, epoch)

    def _late_request(
        self, platform: int, req: BarrierRequest, firings: list[_Fired], now: float, epoch: int
    ) -> None:
        """A request for the generation fired last: a repeat, a completion, or too late."""
        for fired in firings:
            if platform in fired.assigned:
                # It was a candidate and missed the release: send its entry again.
                self._resend(req.key, fired, platform, now, epoch)
                return
        if all(f.complete_knowledge or f.origin < req.epoch for f in firings):
            # Every firing of that generation is fully known, or was decided before this
            # request was even made: the request is simply late (but see _refuse).
            current = max(self._instance(req.key).generation, firings[0].generation + 1)
            self._refuse(platform, req, current, now, epoch)
            return
        # Rebuilt after a failover: park it until the handshake ends, then complete.
        self._completion_waiting.setdefault(req.key, {})[platform] = req
        if self.ready and not self._hold_fire:
            self._complete(req.key, now, epoch)

    def topology_changed(self, now: float) -> None:
        """The master's swarm changed (it became master, someone joined, an unknown platform
        reported): reports that are still on their way may reveal firings it does not know."""
        self._changed_at = now

    def _refuse(
        self, platform: int, req: BarrierRequest, current: int, now: float, epoch: int
    ) -> None:
        """Tell ``platform`` its request is stale — unless it was made for the occasion a
        firing already served (it is released as not chosen by that firing), or the swarm
        changed so recently that a report still on its way may show the request belongs to
        a firing to complete."""
        if req.occasion:
            for firings in self.fired.get(req.key, {}).values():
                for fired in firings:
                    if req.occasion in fired.occasions:
                        # A late candidate of the same occasion: that firing did not need it.
                        fired.assigned.setdefault(platform, (req.part, 0))
                        part, index = fired.assigned[platform]
                        fired.entries[platform] = ReleaseEntry(
                            platform=platform, part=part, index=index
                        )
                        self._launch(req.key, fired, {platform}, now, epoch)
                        return
        if self._park(platform, req, now, epoch):
            return
        if now < self._changed_at + self._config.t_join:
            self._doubtful[(platform, req.key)] = req
            return
        self.notices.append(
            (platform, BarrierStale(key=req.key, generation=req.generation, current=current))
        )

    def _park(self, platform: int, req: BarrierRequest, now: float, epoch: int) -> bool:
        """Hold a request back instead of calling it stale, when it was made under another
        master: in an older epoch than this master's, or in the same epoch number claimed by
        another platform (a rebooted one that heard nobody's epoch may claim it again).

        Then a master of that epoch, on the other side of a partition, may have fired the
        generation with it just before the cut, and the release never reached it: refused
        here, it would move on, and that firing could never be completed. So it waits, up to
        ``doubt_timeout``, for a report (after the heal) that shows such a firing; one that
        does (:meth:`record_released`) completes it with its original entry. A firing of
        that epoch known in full does not settle it: two sides of a partition may each have
        had a master claim the same epoch number, and each fired its own."""
        if req.epoch > epoch or (req.epoch == epoch and req.master in (0, self.platform)):
            return False  # made under this master (or a later one): nothing to wait for
        ident = (platform, req.key)
        until = self._parked.get(ident, (req, now + self._config.doubt_timeout))[1]
        if now >= until:
            del self._parked[ident]
            return False
        self._parked[ident] = (req, until)
        return True

    def _recheck_doubtful(self, now: float, epoch: int) -> None:
        if not self._doubtful or now < self._changed_at + self._config.t_join:
            return
        doubtful, self._doubtful = self._doubtful, {}
        for (platform, _), req in sorted(doubtful.items()):
            self.request(platform, req, now, epoch)

    def record_released(self, platform: int, rec: ReleaseRecord) -> None:
        """A member reports it passed ``rec`` (handshake): rebuild what was fired."""
        gens = self.fired.setdefault(rec.key, {})
        firings = gens.get(rec.generation)
        if firings is None:
            firings = gens[rec.generation] = []
            self._prune(rec.key)
            inst = self.open.get(rec.key)
            if inst is not None and inst.generation <= rec.generation:
                # That generation was fired elsewhere, so was every open one below it: each
                # waiting request waits for completion (a report may show its firing) or, if
                # none is ever known, is routed again then (refused or parked), never dropped.
                del self.open[rec.key]
                for p, r in inst.requests.items():
                    self._completion_waiting.setdefault(rec.key, {})[p] = r
        fired = next(
            (f for f in firings if (f.origin, f.master) == (rec.origin, rec.origin_master)), None
        )
        if fired is None:
            fired = _Fired(
                generation=rec.generation,
                origin=rec.origin,
                master=rec.origin_master,
                outcome=rec.outcome,
                sizes={},
                assigned={},
                complete_knowledge=False,
            )
            firings.append(fired)
        fired.sizes[rec.part] = max(fired.sizes.get(rec.part, 0), rec.size)
        if not rec.assignment or platform in rec.assignment:
            # (A former master reports the firings it decided, in which it may have had no
            # part: that does not make it a candidate of them.)
            fired.assigned[platform] = (rec.part, rec.index)
        if rec.assignment:
            # The reporter saw the whole firing: every candidate and its index is known.
            for other, (part, index) in rec.assignment.items():
                fired.assigned.setdefault(other, (part, index))
                fired.sizes[part] = max(fired.sizes.get(part, 0), index)
            fired.complete_knowledge = True
        for ident, req in list(self._doubtful.items()):
            if ident[1] == rec.key and req.generation == rec.generation:
                del self._doubtful[ident]
                self._completion_waiting.setdefault(rec.key, {})[ident[0]] = req
        for ident, (req, _) in list(self._parked.items()):
            if ident[1] == rec.key and req.generation == rec.generation:
                del self._parked[ident]
                self._completion_waiting.setdefault(rec.key, {})[ident[0]] = req

    def known_generation(self, key: int, generation: int, now: float, epoch: int) -> None:
        """A member reports it knows ``generation`` is the open one for ``key``.

        During the handshake this is only noted: another member's report may still show
        that a waiting request belongs to a firing to complete, not to a stale generation.
        """
        if generation > self._known.get(key, 0):
            self._known[key] = generation
        if self.ready:
            self._advance(key, now, epoch)

    def _advance(self, key: int, now: float, epoch: int) -> None:
        """Open the newest generation members know of; waiting requests of older ones are void."""
        generation = self._known.get(key, 0)
        inst = self._instance(key)
        if generation <= inst.generation:
            return
        for other, old in inst.requests.items():
            self._refuse(other, old, generation, now, epoch)
        self.open[key] = _Instance(generation)

    def member_left(self, platform: int, now: float, epoch: int) -> None:
        for staged in [k for k in self._staged if k[0] == platform]:
            del self._staged[staged]
        for ident in [k for k in self._doubtful if k[0] == platform]:
            del self._doubtful[ident]
        for ident in [k for k in self._parked if k[0] == platform]:
            del self._parked[ident]
        for inst in self.open.values():
            inst.requests.pop(platform, None)
        for waiting in self._completion_waiting.values():
            waiting.pop(platform, None)
        for rel in self.inflight.values():
            rel.unacked.discard(platform)
        self._prune_inflight()
        if self.ready:
            # A need of NEED_ALL shrinks when someone leaves: that may complete a barrier.
            for key in list(self.open):
                self.try_fire(key, now, epoch)

    def on_ack(self, platform: int, key: int, generation: int) -> None:
        for ident, rel in list(self.inflight.items()):
            if ident[0] == key and ident[1] == generation:
                rel.unacked.discard(platform)
                if not rel.unacked:
                    del self.inflight[ident]

    def reported(self, now: float, epoch: int) -> None:
        """A report was applied: when no handshake is on, complete what it revealed now."""
        if self.ready:
            for key in list(self._completion_waiting):
                self._complete(key, now, epoch)

    def become_ready(self, now: float, epoch: int) -> None:
        """The handshake ended: complete interrupted firings, then fire what is due."""
        self.ready = True
        staged, self._staged = self._staged, {}
        # Replay every staged request before anything fires, so the best bids win rather
        # than the first replayed.
        self._hold_fire = True
        for (platform, _), (req, at) in sorted(staged.items()):
            self.request(platform, msgspec.structs.replace(req, age=req.age + now - at), now, epoch)
        self._hold_fire = False
        for key in list(self._completion_waiting):
            self._complete(key, now, epoch)
        for key in list(self._known):
            self._advance(key, now, epoch)
        for key in list(self.open):
            self.try_fire(key, now, epoch)

    # --- decisions ---------------------------------------------------------------------

    def _needs(self, key: int, inst: _Instance) -> dict[int, int]:
        needs: dict[int, int] = {}
        for req in inst.requests.values():
            for part, count in req.need.items():
                resolved = self._resolve_all(key, part) if count == NEED_ALL else count
                needs[part] = min(needs.get(part, resolved), resolved)
        return needs

    def hold(self, key: int, until: float) -> None:
        """Fire nothing of ``key`` before ``until`` (the latest of the holds asked): its
        requests gather meanwhile, and then the best bids are chosen among all of them.
        A timeout still releases the key on time."""
        self._holds[key] = max(until, self._holds.get(key, until))

    def try_fire(self, key: int, now: float, epoch: int) -> None:
        inst = self.open.get(key)
        if inst is None or not inst.requests or not self.ready:
            return
        until = self._holds.get(key)
        if until is not None:
            if now < until:
                return
            del self._holds[key]
        needs = self._needs(key, inst)
        by_part: dict[int, list[tuple[int, BarrierRequest]]] = {}
        for platform, req in inst.requests.items():
            by_part.setdefault(req.part, []).append((platform, req))
        if not needs or any(n < 1 for n in needs.values()):
            return
        if any(len(by_part.get(part, ())) < n for part, n in needs.items()):
            return
        assigned: dict[int, tuple[int, int]] = {}
        for part, items in by_part.items():
            items.sort(key=_order)
            quota = needs.get(part, 0)
            for i, (platform, _) in enumerate(items):
                assigned[platform] = (part, i + 1 if i < quota else 0)
        self._fire(key, inst, assigned, dict(needs), COMPLETE, now, epoch)

    def _fire(
        self,
        key: int,
        inst: _Instance,
        assigned: dict[int, tuple[int, int]],
        sizes: dict[int, int],
        outcome: int,
        now: float,
        epoch: int,
    ) -> None:
        chosen = [
            (platform, part, index, inst.requests[platform])
            for platform, (part, index) in sorted(assigned.items())
            if index > 0
        ]
        scattered = self.scatter(key, inst.generation, chosen) if self.scatter else {}
        entries = {
            platform: ReleaseEntry(
                platform=platform, part=part, index=index, data=scattered.get(platform)
            )
            for platform, (part, index) in assigned.items()
        }
        gathered = [(p, req.data) for p, _, _, req in chosen if req.data is not None]
        fired = _Fired(
            generation=inst.generation,
            origin=epoch,
            master=self.platform,
            outcome=outcome,
            sizes=sizes,
            assigned=assigned,
            complete_knowledge=True,
            occasions=frozenset(r.occasion for r in inst.requests.values() if r.occasion),
            entries=entries,
            gathered=gathered,
        )
        self.fired.setdefault(key, {})[inst.generation] = [fired]
        self._prune(key)
        self.open[key] = _Instance(inst.generation + 1)
        self._launch(key, fired, set(assigned), now, epoch)
        self.events.append(
            BarrierFired(
                key=key,
                generation=inst.generation,
                epoch=epoch,
                outcome=OUTCOME_NAMES[outcome],  # type: ignore[arg-type]
                chosen={p: a for p, a in assigned.items() if a[1] > 0},
                not_chosen=tuple(sorted(p for p, a in assigned.items() if a[1] == 0)),
                completion=False,
            )
        )

    def _launch(self, key: int, fired: _Fired, targets: set[int], now: float, epoch: int) -> None:
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
        rel.unacked |= targets
        rel.due = now + self._config.retry_delay(0, self.first_retry())
        self.broadcasts.extend(rel.packets(targets, self._config.release_chunk))

    def _resend(self, key: int, fired: _Fired, platform: int, now: float, epoch: int) -> None:
        if platform not in fired.entries:
            part, index = fired.assigned[platform]
            fired.entries[platform] = ReleaseEntry(platform=platform, part=part, index=index)
        self._launch(key, fired, {platform}, now, epoch)

    def _prune(self, key: int, keep: int = RECENT_RELEASES) -> None:
        gens = self.fired.get(key, {})
        for old in sorted(gens)[:-keep]:
            del gens[old]

    def _complete(self, key: int, now: float, epoch: int) -> None:
        """Finish firings previous masters started: same generation, the unused indices.

        Waiting requests fill the free slots of the incomplete firings of their generation,
        latest firing first, best bids first; whoever finds no slot passes as not chosen.
        """
        waiting = self._completion_waiting.pop(key, {})
        by_generation: dict[int, list[tuple[int, BarrierRequest]]] = {}
        for platform, req in waiting.items():
            by_generation.setdefault(req.generation, []).append((platform, req))
        unknown: list[tuple[int, BarrierRequest]] = []
        for generation, items in sorted(by_generation.items()):
            firings = self.fired.get(key, {}).get(generation)
            if firings:
                self._complete_generation(key, generation, firings, items, now, epoch)
            else:
                unknown.extend(items)
        gens = self.fired.get(key)
        inst = self.open.get(key)
        if gens and (inst is None or inst.generation <= max(gens)):
            self.open[key] = _Instance(max(gens) + 1)
        for platform, req in unknown:
            # No firing of its generation is known (yet): the open generation, a refusal or
            # a wait for the report of that firing (_refuse) — as if it came now.
            self.request(platform, req, now, epoch)

    def _complete_generation(
        self,
        key: int,
        generation: int,
        firings: list[_Fired],
        waiting: list[tuple[int, BarrierRequest]],
        now: float,
        epoch: int,
    ) -> None:
        items = []
        for platform, req in sorted(waiting, key=_order):
            holder = next((f for f in firings if platform in f.assigned), None)
            if holder is not None:
                # The firing already gave it an entry (someone reported the assignment).
                self._resend(key, holder, platform, now, epoch)
            else:
                items.append((platform, req))
        pending = sorted((f for f in firings if not f.complete_knowledge), key=lambda f: -f.origin)
        assigned: dict[int, dict[int, tuple[int, int]]] = {}
        current = max(self._instance(key).generation, generation + 1)
        for platform, req in items:
            # Only a firing decided no earlier than the request was made can have counted it.
            eligible = [f for f in pending if f.origin >= req.epoch]
            for fired in eligible:
                slot = self._free_slot(fired, req.part)
                if slot is not None:
                    fired.assigned[platform] = (req.part, slot)
                    assigned.setdefault(id(fired), {})[platform] = (req.part, slot)
                    break
            else:
                if not eligible:
                    self._refuse(platform, req, current, now, epoch)
                    continue
                eligible[0].assigned[platform] = (req.part, 0)
                assigned.setdefault(id(eligible[0]), {})[platform] = (req.part, 0)
        for fired in firings:
            # A firing rebuilt from reports stays open to completion: a member that reports
            # later (it rejoins after a false alarm) may still be one of its participants.
            mine = assigned.get(id(fired))
            if not mine:
                continue
            for platform, (part, index) in mine.items():
                fired.entries[platform] = ReleaseEntry(platform=platform, part=part, index=index)
            self._launch(key, fired, set(mine), now, epoch)
            self.events.append(
                BarrierFired(
                    key=key,
                    generation=generation,
                    epoch=epoch,
                    outcome=OUTCOME_NAMES[fired.outcome],  # type: ignore[arg-type]
                    chosen={p: a for p, a in mine.items() if a[1] > 0},
                    not_chosen=tuple(sorted(p for p, a in mine.items() if a[1] == 0)),
                    completion=True,
                )
            )

    @staticmethod
    def _free_slot(fired: _Fired, part: int) -> int | None:
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

    # --- time --------------------------------------------------------------------------

    def tick(self, now: float, epoch: int) -> None:
        """Fire timeouts; retransmit releases to whoever has not acknowledged."""
        if self.ready:
            self._recheck_doubtful(now, epoch)
            for key in [k for k, until in self._holds.items() if now >= until]:
                self.try_fire(key, now, epoch)
                self._holds.pop(key, None)  # over, whether or not the key had requests
            for ident, (req, until) in list(self._parked.items()):
                if now >= until:
                    self.request(ident[0], req, now, epoch)  # refused now, its wait is over
            for key, inst in list(self.open.items()):
                timeout = self._timeout(inst)
                if (
                    timeout is not None
                    and inst.first_at is not None
                    and now >= inst.first_at + timeout
                ):
                    ordered = sorted(inst.requests.items(), key=_order)
                    counters: dict[int, int] = {}
                    assigned: dict[int, tuple[int, int]] = {}
                    for platform, req in ordered:
                        counters[req.part] = counters.get(req.part, 0) + 1
                        assigned[platform] = (req.part, counters[req.part])
                    self._fire(key, inst, assigned, counters, TIMEOUT, now, epoch)
        for rel in list(self.inflight.values()):
            if now >= rel.deadline:
                self.failed.append((rel.key, rel.generation, set(rel.unacked)))
                del self.inflight[(rel.key, rel.generation, rel.origin, rel.master)]
            elif now >= rel.due and rel.unacked:
                rel.retries += 1
                rel.due = now + self._config.retry_delay(rel.retries, self.first_retry())
                rel.epoch = epoch
                self.broadcasts.extend(rel.packets(rel.unacked, self._config.release_chunk))

    @staticmethod
    def _timeout(inst: _Instance) -> float | None:
        timeouts = [r.timeout for r in inst.requests.values() if r.timeout is not None]
        return min(timeouts) if timeouts else None

    def next_deadline(self) -> float | None:
        best: float | None = None
        if self.ready:
            for inst in self.open.values():
                timeout = self._timeout(inst) if inst.requests else None
                if timeout is not None and inst.first_at is not None:
                    t = inst.first_at + timeout
                    best = t if best is None or t < best else best
        for rel in self.inflight.values():
            t = min(rel.due, rel.deadline)
            best = t if best is None or t < best else best
        if self._doubtful and self.ready:
            t = self._changed_at + self._config.t_join
            best = t if best is None or t < best else best
        if self._parked and self.ready:
            t = min(until for _, until in self._parked.values())
            best = t if best is None or t < best else best
        if self._holds and self.ready:
            t = min(self._holds.values())
            best = t if best is None or t < best else best
        return best

    def decided(self, platform: int) -> list[ReleaseRecord]:
        """The firings this master decided or knows in full, as records for a report to its
        successor: a master that steps down right after a firing may be the only one that
        knows it (its release may not have reached anyone yet), and without this record its
        successor could fire the generation again without the first firing's candidates."""
        out = []
        for key, gens in self.fired.items():
            for generation in sorted(gens)[-RECENT_ASSIGNMENTS:]:
                for fired in gens[generation]:
                    if not fired.complete_knowledge or not fired.assigned:
                        continue
                    part, index = fired.assigned.get(platform, (min(fired.sizes, default=0), 0))
                    out.append(
                        ReleaseRecord(
                            key=key,
                            generation=generation,
                            part=part,
                            index=index,
                            size=fired.sizes.get(part, 0),
                            outcome=fired.outcome,
                            origin=fired.origin,
                            assignment=dict(fired.assigned),
                            origin_master=fired.master,
                        )
                    )
        return out

    def _prune_inflight(self) -> None:
        for k in [k for k, r in self.inflight.items() if not r.unacked]:
            del self.inflight[k]


class BarrierMember:
    """A platform's side: its pending requests, the generations it knows, what it passed."""

    def __init__(self, platform: int) -> None:
        self.platform = platform
        self.known: dict[int, int] = {}
        self.pending: dict[int, tuple[BarrierRequest, float]] = {}
        # The last few releases passed per key: a master rebuilding state after a partition
        # may need an older one than the last (the other side moved on meanwhile).
        self.recent: dict[int, deque[ReleaseRecord]] = {}
        self._passed: set[tuple[int, int]] = set()

    def request(
        self,
        key: int,
        need: dict[int, int],
        now: float,
        *,
        part: int = 0,
        bid: float | None = None,
        data: Any = None,
        timeout: float | None = None,
        epoch: int = 0,
        occasion: str = "",
        master: int = 0,
    ) -> BarrierRequest:
        """Record a request for the open generation of ``key`` and return it (to send).

        ``epoch`` is the master epoch this platform follows now, ``master`` its master."""
        if key in self.pending:
            raise ValueError(
                f"platform {self.platform} already waits on barrier key {key} "
                f"(generation {self.pending[key][0].generation}); one request per key at a time"
            )
        if part not in need:
            raise ValueError(f"part {part} is not among the barrier's parts {sorted(need)}")
        for p, n in need.items():
            if n < 1 and n != NEED_ALL:
                raise ValueError(f"part {p} needs {n} participants; need >= 1 or NEED_ALL")
        req = BarrierRequest(
            key=key,
            generation=self.known.get(key, 0),
            need=dict(need),
            part=part,
            bid=float(self.platform if bid is None else bid),
            data=data,
            timeout=timeout,
            epoch=epoch,
            occasion=occasion,
            master=master,
        )
        self.pending[key] = (req, now)
        return req

    def restated(self, now: float) -> list[BarrierRequest]:
        """Pending requests with their age, for a handshake report."""
        out = []
        for req, since in self.pending.values():
            out.append(
                BarrierRequest(
                    key=req.key,
                    generation=req.generation,
                    need=req.need,
                    part=req.part,
                    bid=req.bid,
                    data=req.data,
                    timeout=req.timeout,
                    age=max(0.0, now - since),
                    epoch=req.epoch,
                    occasion=req.occasion,
                    master=req.master,
                )
            )
        return out

    def on_release(self, rel: Release) -> tuple[BarrierReleased | None, bool]:
        """Apply a release; return (event if this platform passes now, whether to acknowledge)."""
        mine = next((e for e in rel.entries if e.platform == self.platform), None)
        pending = self.pending.get(rel.key)
        if mine is None:
            if pending is None:
                # Not a candidate: only learn that this generation has fired. (A candidate
                # whose entry is in another chunk of the release waits for that chunk.)
                self.known[rel.key] = max(self.known.get(rel.key, 0), rel.generation + 1)
            return None, False
        if (rel.key, rel.generation) in self._passed:
            return None, True  # a retransmission: acknowledge again, deliver nothing
        if pending is None or pending[0].generation > rel.generation:
            # A release for a request this platform no longer holds (e.g. it was told the
            # request was stale): acknowledge so the master stops, deliver nothing. (A later
            # generation that names this platform is the master placing a late request.)
            return None, True
        del self.pending[rel.key]
        self._passed.add((rel.key, rel.generation))
        self.known[rel.key] = max(self.known.get(rel.key, 0), rel.generation + 1)
        size = rel.sizes.get(mine.part, 0)
        self.recent.setdefault(rel.key, deque(maxlen=RECENT_RELEASES)).append(
            ReleaseRecord(
                key=rel.key,
                generation=rel.generation,
                part=mine.part,
                index=mine.index,
                size=size,
                outcome=rel.outcome,
                origin=rel.origin,
                origin_master=rel.origin_master,
                assignment=(
                    {e.platform: (e.part, e.index) for e in rel.entries}
                    if rel.total and len(rel.entries) == rel.total
                    else {}
                ),
            )
        )
        event = BarrierReleased(
            key=rel.key,
            generation=rel.generation,
            outcome=OUTCOME_NAMES.get(rel.outcome, "complete"),  # type: ignore[arg-type]
            chosen=mine.index > 0,
            part=mine.part,
            index=mine.index,
            size=size,
            data=mine.data,
            gathered=tuple(rel.gathered),
        )
        return event, True

    def adopt_epoch(self, epoch: int, master: int = 0) -> None:
        """Requests made while no master was known belong to the first epoch followed."""
        for key, (req, since) in list(self.pending.items()):
            if req.epoch == 0:
                adopted = msgspec.structs.replace(req, epoch=epoch, master=master)
                self.pending[key] = (adopted, since)

    def records(self) -> list[ReleaseRecord]:
        """Every recent release this platform passed, for a handshake report (only the newest
        few per key with their whole assignment, to keep the report small)."""
        out = []
        for recs in self.recent.values():
            keep_from = len(recs) - RECENT_ASSIGNMENTS
            for i, rec in enumerate(recs):
                strip = i < keep_from and rec.assignment
                out.append(msgspec.structs.replace(rec, assignment={}) if strip else rec)
        return out

    def on_stale(self, notice: BarrierStale) -> BarrierStaleNotice | None:
        pending = self.pending.get(notice.key)
        self.known[notice.key] = max(self.known.get(notice.key, 0), notice.current)
        if pending is None or pending[0].generation != notice.generation:
            return None
        del self.pending[notice.key]
        return BarrierStaleNotice(
            key=notice.key, generation=notice.generation, current=notice.current
        )

    def cancel(self, key: int) -> bool:
        """Forget the pending request on ``key`` locally (e.g. the task moved on)."""
        return self.pending.pop(key, None) is not None
