"""The master's side of barriers: requests, firing decisions and time (see
:mod:`actorswarm.core.barrier`)."""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable

import msgspec

from actorswarm.core.barrier_completion import Completion
from actorswarm.core.barrier_state import (
    OUTCOME_NAMES,
    Firing,
    OpenGeneration,
    bid_order,
)
from actorswarm.core.events import BarrierFired
from actorswarm.core.wire import (
    COMPLETE,
    MAX_AWAITED,
    NEED_ALL,
    TIMEOUT,
    BarrierRequest,
    ReleaseEntry,
)


class BarrierMaster(Completion):
    """The master's side: collects requests, decides firings, tracks releases in flight.

    ``ready`` is False during the handshake: requests are collected but nothing fires until
    every member has reported, so a new master never fires a generation its predecessor
    already fired.
    """

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
            inst = self.open[req.key] = OpenGeneration(req.generation)
        inst.put(platform, req)
        start = now - req.age
        if inst.first_at is None or start < inst.first_at:
            inst.first_at = start
        if self.ready and not self._hold_fire:
            self.try_fire(req.key, now, epoch)

    def topology_changed(self, now: float) -> None:
        """The master's swarm changed (it became master, someone joined, an unknown platform
        reported): reports that are still on their way may reveal firings it does not know."""
        self._changed_at = now

    def member_left(self, platform: int, now: float, epoch: int) -> None:
        for staged in [k for k in self._staged if k[0] == platform]:
            del self._staged[staged]
        for ident in [k for k in self._doubtful if k[0] == platform]:
            del self._doubtful[ident]
        for ident in [k for k in self._parked if k[0] == platform]:
            del self._parked[ident]
        for inst in self.open.values():
            inst.drop(platform)
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

    def _resolved(self, key: int, inst: OpenGeneration) -> dict[int, tuple[int, int]]:
        """Per part: what it waits for now, the least any request asks of it, and how many
        of its candidates must be in the view (0 unless that least need is NEED_ALL's).

        A need of NEED_ALL is never below the part's candidates: a candidate runs the
        part's actor, even while the resolver's view of who runs what lags behind. But only
        the view's platforms are "all": a request from beyond it (a platform still joining,
        or one the master dropped) must not stand in for a member's."""
        resolved: dict[int, tuple[int, int]] = {}
        for part, count in inst.pairs:
            n = self._resolve_need(key, part, count)
            live = 0
            if count == NEED_ALL:
                n, live = max(n, inst.parts.get(part, 0)), n
            if part not in resolved or n < resolved[part][0]:
                resolved[part] = (n, live)
        return resolved

    def _live_short(self, inst: OpenGeneration, part: int, need: int) -> bool:
        """Whether fewer than ``need`` of the part's candidates are in the view. Only asked
        once the candidates alone are enough, so a request from beyond the view costs one
        pass over the requests, not one per request."""
        live = self.live
        count = sum(1 for p, r in inst.requests.items() if r.part == part and live(p))
        return count < need

    def awaited(self, now: float, view: Callable[[], Collection[int]]) -> list[int]:
        """The platforms of the view (``view``: the master's, itself included; called only
        when needed) a barrier of all still waits for, when at most :data:`MAX_AWAITED` are
        missing and the barrier has waited a first retry's time; ascending, at most
        :data:`MAX_AWAITED`. Only a part that waits for the whole view names anyone (what
        the engine's resolver counts, the platforms running an actor, is not known here)."""
        if not self.ready:
            return []
        missing: set[int] = set()
        whole: Collection[int] | None = None
        for key, inst in self.open.items():
            if inst.first_at is None or now - inst.first_at < self.first_retry():
                continue
            for part, (_, live) in self._resolved(key, inst).items():
                # The candidates outnumber the view's platforms that asked: a lower bound.
                if live < 1 or live - inst.parts.get(part, 0) > MAX_AWAITED:
                    continue
                if whole is None:
                    whole = view()
                if live != len(whole):
                    continue
                missing.update(p for p in whole if p not in inst.requests)
        return sorted(missing)[:MAX_AWAITED]

    def needs_changed(self, now: float, epoch: int, keys: Iterable[int] | None = None) -> None:
        """What some parts of ``keys`` (None: every key) wait for may have changed (a
        platform entered or left an actor): fire those that are now complete."""
        if self.ready:
            for key in list(self.open) if keys is None else [k for k in keys if k in self.open]:
                self.try_fire(key, now, epoch)

    def waiting_occasions(self, key: int) -> tuple[str, ...]:
        """The occasions of the requests waiting at the open generation of ``key``."""
        inst = self.open.get(key)
        if inst is None:
            return ()
        return tuple(sorted({r.occasion for r in inst.requests.values() if r.occasion}))

    def hold(self, key: int, until: float) -> None:
        """Fire nothing of ``key`` before ``until`` (the latest of the holds asked): its
        requests gather meanwhile, and then the best bids are chosen among all of them.
        A timeout still releases the key on time."""
        self._holds[key] = max(until, self._holds.get(key, until))

    def try_fire(self, key: int, now: float, epoch: int) -> None:
        """Fire ``key`` when every part that waits for candidates (need >= 1) has them;
        a part that waits for none (no platform can be its candidate) holds nothing back,
        but at least one part must wait for someone."""
        inst = self.open.get(key)
        if inst is None or not inst.requests or not self.ready:
            return
        until = self._holds.get(key)
        if until is not None:
            if now < until:
                return
            del self._holds[key]
        resolved = self._resolved(key, inst)
        needs = {part: n for part, (n, _) in resolved.items()}
        waiting = {part: n for part, n in needs.items() if n >= 1}
        if not waiting:
            return
        if any(inst.parts.get(part, 0) < n for part, n in waiting.items()):
            return
        if any(
            live >= 1 and self._live_short(inst, part, live) for part, (_, live) in resolved.items()
        ):
            return
        by_part: dict[int, list[tuple[int, BarrierRequest]]] = {}
        for platform, req in inst.requests.items():
            by_part.setdefault(req.part, []).append((platform, req))
        assigned: dict[int, tuple[int, int]] = {}
        for part, items in by_part.items():
            items.sort(key=bid_order)
            quota = needs.get(part, 0)
            for i, (platform, _) in enumerate(items):
                assigned[platform] = (part, i + 1 if i < quota else 0)
        self._fire(key, inst, assigned, dict(needs), COMPLETE, now, epoch)

    def _fire(
        self,
        key: int,
        inst: OpenGeneration,
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
        gathered = (
            [(p, req.data) for p, _, _, req in chosen if req.data is not None]
            if self.gathers(key)
            else []
        )
        fired = Firing(
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
        self.open[key] = OpenGeneration(inst.generation + 1)
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
                timeout = inst.timeout()
                if (
                    timeout is not None
                    and inst.first_at is not None
                    and now >= inst.first_at + timeout
                ):
                    ordered = sorted(inst.requests.items(), key=bid_order)
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
                rel.due = now + self.retry_delay(rel.retries, self.first_retry(), len(rel.unacked))
                rel.epoch = epoch
                self.broadcasts.extend(rel.packets(rel.unacked, self._config.release_chunk))

    def next_deadline(self) -> float | None:
        best: float | None = None
        if self.ready:
            for inst in self.open.values():
                timeout = inst.timeout()
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


__all__ = ["BarrierMaster"]
