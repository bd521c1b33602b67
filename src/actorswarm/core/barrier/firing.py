"""When a key fires and whom it chooses, the master's side (see :mod:`actorswarm.core.barrier`):
the open generation's requests against what each part waits for, holds, timeouts, and the
firing itself (its record, its release, its event).
"""

from __future__ import annotations

from collections.abc import Callable, Collection

from actorswarm.core.barrier.releases import Releases
from actorswarm.core.barrier.shared import (
    OUTCOME_NAMES,
    BarrierOutput,
    Firing,
    Gathers,
    NeedResolver,
    OpenGeneration,
    Scatter,
    bid_order,
)
from actorswarm.core.barrier.table import BarrierTable
from actorswarm.core.events import BarrierFired
from actorswarm.core.wire import (
    COMPLETE,
    MAX_AWAITED,
    NEED_ALL,
    TIMEOUT,
    BarrierRequest,
    ReleaseEntry,
)


class Trigger:
    """Fires the open generations of ``table`` when they can fire; launches their releases
    with ``releases`` and reports each firing to ``output``.

    The hooks: ``resolve_need`` (what a part waits for now), ``scatter`` (per-participant
    data of a release; None: none), ``gathers`` (whether a key's release carries the chosen
    requests' data to all; a key whose data only ``scatter`` reads says no, and its release
    chunks stay O(release_chunk) bytes rather than O(N) each), ``live`` (whether a platform
    is in the master's view, itself included: a part that waits for every platform counts
    only their requests, so one from beyond the view — a platform still joining, or one
    the master dropped — never stands in for a member's) and ``first_retry`` (how long a
    barrier of all waits before its heartbeat names whom it awaits). ``platform`` is this
    master's ID: with the epoch, the name of the firings it decides.
    """

    def __init__(
        self,
        table: BarrierTable,
        releases: Releases,
        output: BarrierOutput,
        *,
        platform: int,
        resolve_need: NeedResolver,
        scatter: Scatter | None,
        gathers: Gathers,
        live: Callable[[int], bool],
        first_retry: Callable[[], float],
    ) -> None:
        self._table = table
        self._releases = releases
        self._output = output
        self._platform = platform
        self._resolve_need = resolve_need
        self._scatter = scatter
        self._gathers = gathers
        self._live = live
        self._first_retry = first_retry
        # Keys that do not fire before a time (hold), whatever requests they have.
        self._holds: dict[int, float] = {}

    def admit(self, platform: int, req: BarrierRequest, now: float) -> OpenGeneration:
        """Count ``req`` at the open generation of its key (the one it names)."""
        inst = self._table.instance(req.key)
        inst.put(platform, req)
        start = now - req.age
        if inst.first_at is None or start < inst.first_at:
            inst.first_at = start
        return inst

    def hold(self, key: int, until: float) -> None:
        """Fire nothing of ``key`` before ``until`` (the latest of the holds asked): its
        requests gather meanwhile, and then the best bids are chosen among all of them.
        A timeout still releases the key on time."""
        self._holds[key] = max(until, self._holds.get(key, until))

    def try_fire(self, key: int, now: float, epoch: int) -> None:
        """Fire ``key`` when every part that waits for candidates (need >= 1) has them;
        a part that waits for none (no platform can be its candidate) holds nothing back,
        but at least one part must wait for someone."""
        inst = self._table.open.get(key)
        if inst is None or not inst.requests or not self._table.ready:
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

    def tick_holds(self, now: float, epoch: int) -> None:
        """Fire the keys whose hold is over."""
        for key in [k for k, until in self._holds.items() if now >= until]:
            self.try_fire(key, now, epoch)
            self._holds.pop(key, None)  # over, whether or not the key had requests

    def tick_timeouts(self, now: float, epoch: int) -> None:
        """Release every candidate of a key whose shortest timeout ran out, chosen all."""
        for key, inst in list(self._table.open.items()):
            timeout = inst.timeout()
            if timeout is not None and inst.first_at is not None and now >= inst.first_at + timeout:
                ordered = sorted(inst.requests.items(), key=bid_order)
                counters: dict[int, int] = {}
                assigned: dict[int, tuple[int, int]] = {}
                for platform, req in ordered:
                    counters[req.part] = counters.get(req.part, 0) + 1
                    assigned[platform] = (req.part, counters[req.part])
                self._fire(key, inst, assigned, counters, TIMEOUT, now, epoch)

    def next_deadline(self) -> float | None:
        """The next timeout or end of a hold (the table must be ready)."""
        times = [
            inst.first_at + timeout
            for inst in self._table.open.values()
            if (timeout := inst.timeout()) is not None and inst.first_at is not None
        ]
        times.extend(self._holds.values())
        return min(times, default=None)

    def awaited(self, now: float, view: Callable[[], Collection[int]]) -> list[int]:
        """The platforms of the view (``view``: the master's, itself included; called only
        when needed) a barrier of all still waits for, when at most :data:`MAX_AWAITED` are
        missing and the barrier has waited a first retry's time; ascending, at most
        :data:`MAX_AWAITED`. Only a part that waits for the whole view names anyone (what
        the engine's resolver counts, the platforms running an actor, is not known here)."""
        if not self._table.ready:
            return []
        missing: set[int] = set()
        whole: Collection[int] | None = None
        for key, inst in self._table.open.items():
            if inst.first_at is None or now - inst.first_at < self._first_retry():
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
        live = self._live
        count = sum(1 for p, r in inst.requests.items() if r.part == part and live(p))
        return count < need

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
        scattered = self._scatter(key, inst.generation, chosen) if self._scatter else {}
        entries = {
            platform: ReleaseEntry(
                platform=platform, part=part, index=index, data=scattered.get(platform)
            )
            for platform, (part, index) in assigned.items()
        }
        gathered = (
            [(p, req.data) for p, _, _, req in chosen if req.data is not None]
            if self._gathers(key)
            else []
        )
        fired = Firing(
            generation=inst.generation,
            origin=epoch,
            master=self._platform,
            outcome=outcome,
            sizes=sizes,
            assigned=assigned,
            complete_knowledge=True,
            occasions=frozenset(r.occasion for r in inst.requests.values() if r.occasion),
            entries=entries,
            gathered=gathered,
        )
        table = self._table
        table.fired.setdefault(key, {})[inst.generation] = [fired]
        table.prune(key)
        table.open[key] = OpenGeneration(inst.generation + 1)
        self._releases.launch(key, fired, set(assigned), now, epoch)
        self._output.fired(
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


__all__ = ["Trigger"]
