"""Late requests and failover completion, the master's side (see
:mod:`actorswarm.core.barrier`): a request for a generation already fired is a repeat, a
completion or too late; a firing a predecessor decided is completed from the members'
reports so that every chosen candidate passes the same generation exactly once.
"""

from __future__ import annotations

from collections.abc import Callable

import msgspec

from actorswarm.core.barrier.firing import Trigger
from actorswarm.core.barrier.releases import Releases
from actorswarm.core.barrier.shared import (
    OUTCOME_NAMES,
    BarrierOutput,
    Firing,
    OpenGeneration,
    bid_order,
)
from actorswarm.core.barrier.table import BarrierTable
from actorswarm.core.config import CoreConfig
from actorswarm.core.events import BarrierFired
from actorswarm.core.wire import TIMEOUT, BarrierRequest, BarrierStale, ReleaseEntry, ReleaseRecord

#: Routes a request as if it came now: (platform, request, now, epoch).
Route = Callable[[int, BarrierRequest, float, int], None]


class Completion:
    """Late requests, refusals that wait for reports, and completions of known firings.

    It reads and writes ``table``'s firings and open generations, sends entries again with
    ``releases``, asks ``trigger`` to fire a renewed request, tells ``output`` of stale
    requests and completed firings, and hands a request it cannot place yet back to
    ``route`` (the master's way in) when its wait is over. ``platform`` is this master's ID.
    """

    def __init__(
        self,
        config: CoreConfig,
        table: BarrierTable,
        releases: Releases,
        trigger: Trigger,
        output: BarrierOutput,
        *,
        platform: int,
        route: Route,
    ) -> None:
        self._config = config
        self._table = table
        self._releases = releases
        self._trigger = trigger
        self._output = output
        self._platform = platform
        self._route = route
        # Requests for a generation a previous master fired, waiting to be completed.
        self._waiting: dict[int, dict[int, BarrierRequest]] = {}
        # The newest open generation members reported per key.
        self._known: dict[int, int] = {}
        # Requests refused while reports may still be on their way (see refuse).
        self._doubtful: dict[tuple[int, int], BarrierRequest] = {}
        self._changed_at = -float("inf")
        # Requests older than every firing known of their generation, with how long they
        # wait for a report of the firing that may have chosen them (see late_request).
        self._parked: dict[tuple[int, int], tuple[BarrierRequest, float]] = {}

    def topology_changed(self, now: float) -> None:
        """The master's swarm changed (it became master, someone joined, an unknown platform
        reported): reports still on their way may reveal firings it does not know."""
        self._changed_at = now

    def member_left(self, platform: int) -> None:
        """Forget the doubtful and parked requests of ``platform``."""
        for ident in [k for k in self._doubtful if k[0] == platform]:
            del self._doubtful[ident]
        for ident in [k for k in self._parked if k[0] == platform]:
            del self._parked[ident]

    def forget_waiting(self, platform: int) -> None:
        """None of ``platform``'s requests waits for completion any more (it left)."""
        for waiting in self._waiting.values():
            waiting.pop(platform, None)

    def waiting_keys(self) -> list[int]:
        """The keys with requests waiting for completion."""
        return list(self._waiting)

    def known_keys(self) -> list[int]:
        """The keys whose open generation members reported."""
        return list(self._known)

    def tick_parked(self, now: float, epoch: int) -> None:
        """Route again the parked requests whose wait is over: refused now."""
        for ident, (req, until) in list(self._parked.items()):
            if now >= until:
                self._route(ident[0], req, now, epoch)

    def next_deadline(self) -> float | None:
        """When the doubtful requests are decided or a parked one's wait ends (asked only
        of a ready table)."""
        times = []
        if self._doubtful:
            times.append(self._changed_at + self._config.t_join)
        if self._parked:
            times.append(min(until for _, until in self._parked.values()))
        return min(times, default=None)

    def late_request(
        self, platform: int, req: BarrierRequest, firings: list[Firing], now: float, epoch: int
    ) -> None:
        """A request for the generation fired last: a repeat, a completion, or too late."""
        for fired in firings:
            if platform in fired.assigned:
                # It was a candidate and missed the release: send its entry again.
                self._releases.resend(req.key, fired, platform, now, epoch)
                return
        if all(f.complete_knowledge or f.origin < req.epoch for f in firings):
            # Every firing of that generation is fully known, or was decided before this
            # request was even made: the request is simply late (but see refuse).
            current = max(self._table.instance(req.key).generation, firings[0].generation + 1)
            self.refuse(platform, req, current, now, epoch)
            return
        # Rebuilt after a failover: park it until the handshake ends, then complete.
        self._waiting.setdefault(req.key, {})[platform] = req
        if self._table.may_fire:
            self.complete(req.key, now, epoch)

    def refuse(
        self, platform: int, req: BarrierRequest, current: int, now: float, epoch: int
    ) -> None:
        """Tell ``platform`` its request is stale — unless it was made for the occasion a
        firing already served (it is released as not chosen by that firing), or the swarm
        changed so recently that a report still on its way may show the request belongs to
        a firing to complete."""
        if req.occasion:
            for firings in self._table.fired.get(req.key, {}).values():
                for fired in firings:
                    if req.occasion in fired.occasions:
                        # A late candidate of the same occasion: that firing did not need it.
                        fired.assigned.setdefault(platform, (req.part, 0))
                        part, index = fired.assigned[platform]
                        fired.entries[platform] = ReleaseEntry(
                            platform=platform, part=part, index=index
                        )
                        self._releases.launch(req.key, fired, {platform}, now, epoch)
                        return
        if self._park(platform, req, now, epoch):
            return
        if now < self._changed_at + self._config.t_join:
            self._doubtful[(platform, req.key)] = req
            return
        if req.renew and self._renew(platform, req, current, now, epoch):
            return
        self._output.stale(
            platform, BarrierStale(key=req.key, generation=req.generation, current=current)
        )

    def _renew(
        self, platform: int, req: BarrierRequest, current: int, now: float, epoch: int
    ) -> bool:
        """Count a stale request that asks for it (``renew``) for the open generation
        ``current`` — only when it alone fires that generation, now: a release to its
        platform alone. True when it did; the caller refuses the request otherwise.

        What the requester would have done, told it is stale, is ask again for ``current``:
        this saves that round trip (four packets: on a key that many platforms pass one at
        a time, as in the paper's Table I, nearly every request crossed a firing on its way
        and was refused once). Why only alone: the requester still believes it asked for
        the generation it named. Should the release be lost and this master fail, its
        report to the next master names that generation, so a firing of ``current`` that
        another platform passed could not be completed for it; a firing no one else passed
        needs no completion."""
        if not self._table.may_fire:
            return False
        inst = self._table.instance(req.key)
        if inst.generation != current or inst.requests:
            return False
        first_at = inst.first_at
        inst.put(platform, msgspec.structs.replace(req, generation=current))
        inst.first_at = now - req.age
        self._trigger.try_fire(req.key, now, epoch)
        if self._table.open.get(req.key) is not inst:
            return True  # fired, with its one request
        inst.drop(platform)
        inst.first_at = first_at
        return False

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
        if req.epoch > epoch or (req.epoch == epoch and req.master in (0, self._platform)):
            return False  # made under this master (or a later one): nothing to wait for
        ident = (platform, req.key)
        until = self._parked.get(ident, (req, now + self._config.doubt_timeout))[1]
        if now >= until:
            del self._parked[ident]
            return False
        self._parked[ident] = (req, until)
        return True

    def recheck_doubtful(self, now: float, epoch: int) -> None:
        if not self._doubtful or now < self._changed_at + self._config.t_join:
            return
        doubtful, self._doubtful = self._doubtful, {}
        for (platform, _), req in sorted(doubtful.items()):
            self._route(platform, req, now, epoch)

    def record_released(self, platform: int, rec: ReleaseRecord) -> None:
        """A member reports it passed ``rec`` (handshake): rebuild what was fired."""
        gens = self._table.fired.setdefault(rec.key, {})
        firings = gens.get(rec.generation)
        if firings is None:
            firings = gens[rec.generation] = []
            self._table.prune(rec.key)
            inst = self._table.open.get(rec.key)
            if inst is not None and inst.generation <= rec.generation:
                # That generation was fired elsewhere, so was every open one below it: each
                # waiting request waits for completion (a report may show its firing) or, if
                # none is ever known, is routed again then (refused or parked), never dropped.
                del self._table.open[rec.key]
                for p, r in inst.requests.items():
                    self._waiting.setdefault(rec.key, {})[p] = r
        fired = next(
            (f for f in firings if (f.origin, f.master) == (rec.origin, rec.origin_master)), None
        )
        if fired is None:
            fired = Firing(
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
        named = rec.assignment or rec.partial
        if not named or platform in named:
            # (A former master reports the firings it decided or completed, in which it may
            # have had no part: that does not make it a candidate of them.)
            fired.assigned[platform] = (rec.part, rec.index)
        for other, (part, index) in named.items():
            # Candidates the reporter saw: all of them, or (partial) some, e.g. those a
            # completion added after another reporter saw the firing whole.
            fired.assigned.setdefault(other, (part, index))
            fired.sizes[part] = max(fired.sizes.get(part, 0), index)
        if rec.assignment:
            # The reporter saw the whole firing as its master decided it.
            fired.complete_knowledge = True
        for ident, req in list(self._doubtful.items()):
            if ident[1] == rec.key and req.generation == rec.generation:
                del self._doubtful[ident]
                self._waiting.setdefault(rec.key, {})[ident[0]] = req
        for ident, (req, _) in list(self._parked.items()):
            if ident[1] == rec.key and req.generation == rec.generation:
                del self._parked[ident]
                self._waiting.setdefault(rec.key, {})[ident[0]] = req

    def known_generation(self, key: int, generation: int, now: float, epoch: int) -> None:
        """A member reports it knows ``generation`` is the open one for ``key``.

        During the handshake this is only noted: another member's report may still show
        that a waiting request belongs to a firing to complete, not to a stale generation.
        """
        if generation > self._known.get(key, 0):
            self._known[key] = generation
        if self._table.ready:
            self.advance(key, now, epoch)

    def advance(self, key: int, now: float, epoch: int) -> None:
        """Open the newest generation members know of; waiting requests of older ones are void."""
        generation = self._known.get(key, 0)
        inst = self._table.instance(key)
        if generation <= inst.generation:
            return
        for other, old in inst.requests.items():
            self.refuse(other, old, generation, now, epoch)
        self._table.open[key] = OpenGeneration(generation)

    def reported(self, now: float, epoch: int) -> None:
        """A report was applied: when no handshake is on, complete what it revealed now."""
        if self._table.ready:
            for key in list(self._waiting):
                self.complete(key, now, epoch)

    def complete(self, key: int, now: float, epoch: int) -> None:
        """Finish firings previous masters started: same generation, the unused indices.

        Waiting requests fill the free slots of the incomplete firings of their generation,
        latest firing first, best bids first; whoever finds no slot passes as not chosen.
        """
        waiting = self._waiting.pop(key, {})
        by_generation: dict[int, list[tuple[int, BarrierRequest]]] = {}
        for platform, req in waiting.items():
            by_generation.setdefault(req.generation, []).append((platform, req))
        unknown: list[tuple[int, BarrierRequest]] = []
        for generation, items in sorted(by_generation.items()):
            firings = self._table.fired.get(key, {}).get(generation)
            if firings:
                self._complete_generation(key, generation, firings, items, now, epoch)
            else:
                unknown.extend(items)
        gens = self._table.fired.get(key)
        inst = self._table.open.get(key)
        if gens and (inst is None or inst.generation <= max(gens)):
            self._table.open[key] = OpenGeneration(max(gens) + 1)
        for platform, req in unknown:
            # No firing of its generation is known (yet): the open generation, a refusal or
            # a wait for the report of that firing (refuse) — as if it came now.
            self._route(platform, req, now, epoch)

    def _complete_generation(
        self,
        key: int,
        generation: int,
        firings: list[Firing],
        waiting: list[tuple[int, BarrierRequest]],
        now: float,
        epoch: int,
    ) -> None:
        items = []
        for platform, req in sorted(waiting, key=bid_order):
            holder = next((f for f in firings if platform in f.assigned), None)
            if holder is not None:
                # The firing already gave it an entry (someone reported the assignment).
                self._releases.resend(key, holder, platform, now, epoch)
            else:
                items.append((platform, req))
        pending = sorted((f for f in firings if not f.complete_knowledge), key=lambda f: -f.origin)
        assigned: dict[int, dict[int, tuple[int, int]]] = {}
        current = max(self._table.instance(key).generation, generation + 1)
        for platform, req in items:
            # Only a firing decided no earlier than the request was made can have counted it.
            eligible = [f for f in pending if f.origin >= req.epoch]
            for fired in eligible:
                slot = _free_slot(fired, req.part)
                if slot is not None:
                    fired.assigned[platform] = (req.part, slot)
                    assigned.setdefault(id(fired), {})[platform] = (req.part, slot)
                    break
            else:
                if not eligible:
                    self.refuse(platform, req, current, now, epoch)
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
            self._releases.launch(key, fired, set(mine), now, epoch)
            self._output.fired(
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


__all__ = ["Completion", "Route"]
