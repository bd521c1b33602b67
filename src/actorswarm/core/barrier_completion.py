"""Late requests and failover completion, the master's side (see
:mod:`actorswarm.core.barrier`): a request for a generation already fired is a repeat, a
completion or too late; a firing a predecessor decided is completed from the members'
reports so that every chosen candidate passes the same generation exactly once.
"""

from __future__ import annotations

import msgspec

from actorswarm.core.barrier_state import (
    OUTCOME_NAMES,
    Firing,
    MasterState,
    OpenGeneration,
    bid_order,
)
from actorswarm.core.events import BarrierFired
from actorswarm.core.wire import BarrierRequest, BarrierStale, ReleaseEntry, ReleaseRecord


class Completion(MasterState):
    """Late requests, refusals that wait for reports, and completions of known firings."""

    def _late_request(
        self, platform: int, req: BarrierRequest, firings: list[Firing], now: float, epoch: int
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
        if req.renew and self._renew(platform, req, current, now, epoch):
            return
        self.notices.append(
            (platform, BarrierStale(key=req.key, generation=req.generation, current=current))
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
        if not self.ready or self._hold_fire:
            return False
        inst = self._instance(req.key)
        if inst.generation != current or inst.requests:
            return False
        first_at = inst.first_at
        inst.put(platform, msgspec.structs.replace(req, generation=current))
        inst.first_at = now - req.age
        self.try_fire(req.key, now, epoch)
        if self.open.get(req.key) is not inst:
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
        self.open[key] = OpenGeneration(generation)

    def reported(self, now: float, epoch: int) -> None:
        """A report was applied: when no handshake is on, complete what it revealed now."""
        if self.ready:
            for key in list(self._completion_waiting):
                self._complete(key, now, epoch)

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
            self.open[key] = OpenGeneration(max(gens) + 1)
        for platform, req in unknown:
            # No firing of its generation is known (yet): the open generation, a refusal or
            # a wait for the report of that firing (_refuse) — as if it came now.
            self.request(platform, req, now, epoch)

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


__all__ = ["Completion"]
