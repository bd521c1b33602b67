"""The master's side of barriers (see :mod:`actorswarm.core.barrier`): a coordinator that
routes each request and each tick to its parts — the table (:mod:`.table`), the firing
rules (:mod:`.firing`), the releases in flight (:mod:`.releases`) and the completion of
late requests and of a predecessor's firings (:mod:`.completion`) — and stages the
requests of a handshake."""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable

import msgspec

from actorswarm.core.barrier.completion import Completion
from actorswarm.core.barrier.firing import Trigger
from actorswarm.core.barrier.releases import Releases
from actorswarm.core.barrier.shared import (
    BarrierOutput,
    Gathers,
    NeedResolver,
    OpenGeneration,
    Scatter,
)
from actorswarm.core.barrier.table import BarrierTable
from actorswarm.core.config import CoreConfig
from actorswarm.core.wire import BarrierRequest, ReleaseRecord


class BarrierMaster:
    """The master's side: collects requests, decides firings, tracks releases in flight;
    everything it decides goes to ``output``.

    ``ready`` is False during the handshake: requests are staged but nothing fires until
    every member has reported, so a new master never fires a generation its predecessor
    already fired. The hooks (:class:`~.firing.Trigger`, :class:`~.releases.Releases`) have
    defaults for a table without a node: the need asked for, no scatter, every request
    gathered, everyone in the view, and the configured retry delays.
    """

    def __init__(
        self,
        config: CoreConfig,
        output: BarrierOutput,
        *,
        resolve_need: NeedResolver,
        platform: int = 0,
        scatter: Scatter | None = None,
        gathers: Gathers = lambda key: True,
        live: Callable[[int], bool] = lambda platform: True,
        first_retry: Callable[[], float] | None = None,
        retry_delay: Callable[[int, float, int], float] | None = None,
    ) -> None:
        first = first_retry or (lambda: config.retry_base)
        self.table = BarrierTable()
        self.releases = Releases(
            config,
            output,
            first_retry=first,
            retry_delay=retry_delay or (lambda k, first, answers: config.retry_delay(k, first)),
        )
        self.trigger = Trigger(
            self.table,
            self.releases,
            output,
            platform=platform,
            resolve_need=resolve_need,
            scatter=scatter,
            gathers=gathers,
            live=live,
            first_retry=first,
        )
        self.completion = Completion(
            config,
            self.table,
            self.releases,
            self.trigger,
            output,
            platform=platform,
            route=self.request,
        )
        # Requests received during the handshake, with their arrival time.
        self._staged: dict[tuple[int, int], tuple[BarrierRequest, float]] = {}

    @property
    def ready(self) -> bool:
        """Whether the handshake is over (see the class)."""
        return self.table.ready

    @ready.setter
    def ready(self, value: bool) -> None:
        self.table.ready = value

    def request(self, platform: int, req: BarrierRequest, now: float, epoch: int) -> None:
        """A member's request (or its re-statement in a handshake report).

        During the handshake requests are only staged: until every report is in, the master
        cannot tell a stale request from one that belongs to a firing to complete.
        """
        table = self.table
        if not table.ready:
            self._staged[(platform, req.key)] = (req, now)
            return
        firings = table.firings(req.key, req.generation)
        if firings:
            self.completion.late_request(platform, req, firings, now, epoch)
            return
        inst = table.instance(req.key)
        if req.generation < inst.generation:
            self.completion.refuse(platform, req, inst.generation, now, epoch)
            return
        if req.generation > inst.generation:
            # The member saw a firing this master does not know of (a predecessor's):
            # move on; whoever waited on the old generation is refused.
            for other, old in inst.requests.items():
                self.completion.refuse(other, old, req.generation, now, epoch)
            table.open[req.key] = OpenGeneration(req.generation)
        self.trigger.admit(platform, req, now)
        if table.may_fire:
            self.trigger.try_fire(req.key, now, epoch)

    def topology_changed(self, now: float) -> None:
        """The master's swarm changed (it became master, someone joined, an unknown platform
        reported): reports that are still on their way may reveal firings it does not know."""
        self.completion.topology_changed(now)

    def member_left(self, platform: int, now: float, epoch: int) -> None:
        for staged in [k for k in self._staged if k[0] == platform]:
            del self._staged[staged]
        self.completion.member_left(platform)
        for inst in self.table.open.values():
            inst.drop(platform)
        self.completion.forget_waiting(platform)
        self.releases.member_left(platform)
        if self.table.ready:
            # A need of NEED_ALL shrinks when someone leaves: that may complete a barrier.
            for key in list(self.table.open):
                self.trigger.try_fire(key, now, epoch)

    def on_ack(self, platform: int, key: int, generation: int) -> None:
        self.releases.on_ack(platform, key, generation)

    def become_ready(self, now: float, epoch: int) -> None:
        """The handshake ended: complete interrupted firings, then fire what is due."""
        table = self.table
        table.ready = True
        staged, self._staged = self._staged, {}
        # Replay every staged request before anything fires, so the best bids win rather
        # than the first replayed.
        table.holding = True
        for (platform, _), (req, at) in sorted(staged.items()):
            self.request(platform, msgspec.structs.replace(req, age=req.age + now - at), now, epoch)
        table.holding = False
        for key in self.completion.waiting_keys():
            self.completion.complete(key, now, epoch)
        for key in self.completion.known_keys():
            self.completion.advance(key, now, epoch)
        for key in list(table.open):
            self.trigger.try_fire(key, now, epoch)

    def record_released(self, platform: int, rec: ReleaseRecord) -> None:
        """A member reports it passed ``rec`` (handshake): rebuild what was fired."""
        self.completion.record_released(platform, rec)

    def known_generation(self, key: int, generation: int, now: float, epoch: int) -> None:
        """A member reports it knows ``generation`` is the open one for ``key``."""
        self.completion.known_generation(key, generation, now, epoch)

    def reported(self, now: float, epoch: int) -> None:
        """A report was applied: when no handshake is on, complete what it revealed now."""
        self.completion.reported(now, epoch)

    def decided(self, platform: int) -> list[ReleaseRecord]:
        """The firings to report to a successor (:meth:`.table.BarrierTable.decided`)."""
        return self.table.decided(platform)

    def awaited(self, now: float, view: Callable[[], Collection[int]]) -> list[int]:
        """Whom a barrier of all still waits for (:meth:`.firing.Trigger.awaited`)."""
        return self.trigger.awaited(now, view)

    def needs_changed(self, now: float, epoch: int, keys: Iterable[int] | None = None) -> None:
        """What some parts of ``keys`` (None: every key) wait for may have changed (a
        platform entered or left an actor): fire those that are now complete."""
        if self.table.ready:
            open_keys = self.table.open
            for key in list(open_keys) if keys is None else [k for k in keys if k in open_keys]:
                self.trigger.try_fire(key, now, epoch)

    def waiting_occasions(self, key: int) -> tuple[str, ...]:
        """The occasions of the requests waiting at the open generation of ``key``."""
        return self.table.waiting_occasions(key)

    def hold(self, key: int, until: float) -> None:
        """Fire nothing of ``key`` before ``until`` (:meth:`.firing.Trigger.hold`)."""
        self.trigger.hold(key, until)

    def tick(self, now: float, epoch: int) -> None:
        """Decide the doubtful requests, fire held keys and timeouts, refuse parked requests
        whose wait is over; retransmit releases to whoever has not acknowledged."""
        if self.table.ready:
            self.completion.recheck_doubtful(now, epoch)
            self.trigger.tick_holds(now, epoch)
            self.completion.tick_parked(now, epoch)
            self.trigger.tick_timeouts(now, epoch)
        self.releases.tick(now, epoch)

    def next_deadline(self) -> float | None:
        times = [self.releases.next_deadline()]
        if self.table.ready:
            times += [self.trigger.next_deadline(), self.completion.next_deadline()]
        return min((t for t in times if t is not None), default=None)


__all__ = ["BarrierMaster"]
