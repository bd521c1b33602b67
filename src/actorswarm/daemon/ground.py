"""The ground station over a real transport: a session the ``gs`` commands run in.

A :class:`GroundSession` opens the ground station's endpoint
(:class:`~actorswarm.ground.station.GroundStation`, platform 0) on Zenoh and drives it with
:func:`~actorswarm.daemon.loop.serve` in the background; a command calls :meth:`do` to act
(deploy, start, inject...) and :meth:`wait_for` to wait for the swarm's answers. Each
session is a new *incarnation* of the ground station (the wall clock in microseconds: two
``gs`` commands run within one second, e.g. ``deploy`` then ``start`` from a script, must still
differ), so the platforms never take a new session's messages for repeats of an old one's.
The swarm does not depend on a ground station being there: sessions come and go.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Collection
from types import TracebackType
from typing import TypeVar

from actorswarm.core.config import CoreConfig
from actorswarm.daemon.loop import Inbox, clock, flush, serve
from actorswarm.ground.silence import explain
from actorswarm.ground.station import GroundStation
from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import CLOSE_WAIT_S, ZenohSettings, ZenohTransport

__all__ = ["GroundSession"]

_T = TypeVar("_T")

#: How often :meth:`GroundSession.wait_for` looks at its condition, seconds.
_POLL = 0.05


def session_incarnation() -> int:
    """A new ground-station session's incarnation: the wall clock in microseconds.

    It must exceed every earlier session's, or the platforms drop the new session's packets
    as replays of the old one's (same sender, same incarnation, sequence numbers from 1
    again). Seconds were not enough: ``gs deploy`` and ``gs start`` often run in one second.
    Within one process (a program opening sessions back to back) it also never repeats.
    """
    _last[0] = max(time.time_ns() // 1_000, _last[0] + 1)
    return _last[0]


#: The incarnation this process gave its last session.
_last = [0]


class GroundSession:
    """``async with GroundSession(swarm, settings) as gs:`` — the ground station is
    ``gs.station``. ``patience`` (seconds) is how long its commands are retransmitted before
    a platform is given up on (:attr:`GroundStation.unreachable`); at least the core's
    ``delivery_deadline``."""

    def __init__(
        self,
        swarm: str,
        settings: ZenohSettings | None = None,
        guard: PacketGuard | None = None,
        *,
        patience: float | None = None,
    ) -> None:
        self.swarm = swarm
        self.settings = settings or ZenohSettings()
        #: Seals the operator's packets (HMAC and Ed25519 signature) and checks the swarm's.
        self.guard = guard or PacketGuard.insecure()
        # A command that waits ``patience`` seconds for its answers keeps retransmitting that
        # long: with the core's default deadline (10 s) a platform whose link came up late
        # would be given up on while the operator is still told to wait.
        config = CoreConfig()
        if patience is not None and patience > config.delivery_deadline:
            config = config.replace(delivery_deadline=patience)
        self.station = GroundStation(
            swarm=swarm, now=clock(), incarnation=session_incarnation(), config=config
        )
        self._inbox: Inbox | None = None
        self._stop = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._transport: ZenohTransport | None = None

    async def __aenter__(self) -> GroundSession:
        self._transport = ZenohTransport(self.swarm, 0, self.settings)
        inbox = self._inbox = Inbox(asyncio.get_running_loop(), self._transport)
        # The incarnation is taken now, when the session is about to speak, not when it was
        # made: opening Zenoh takes a while, and a long-lived session (gs record) that
        # renewed itself meanwhile would otherwise outrank this one before it said a word.
        self.station.renew(session_incarnation())
        self._task = asyncio.create_task(
            serve(self.station, self._transport, inbox, self._stop, guard=self.guard)
        )
        return self

    async def __aexit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._stop.set()
        if self._task is not None:
            await self._task
        if self._transport is not None:
            # The last acknowledgements went out with the serve task's end. Zenoh's own
            # close waits for every peer's goodbye, seconds over a lossy link: a command
            # has its answers and need not wait for it (``closing``, the CLI's exit).
            self._transport.close(wait=CLOSE_WAIT_S)

    def do(self, action: Callable[[GroundStation, float], _T]) -> _T:
        """Run ``action(station, now)`` now and send what it produced."""
        result = action(self.station, clock())
        if self._transport is not None:
            flush(self.station, self._transport, self.guard)
        return result

    async def wait_for(self, condition: Callable[[], bool], timeout: float) -> bool:
        """Wait until ``condition()`` holds (True) or ``timeout`` seconds pass (False)."""
        end = clock() + timeout
        while not condition():
            if clock() >= end:
                return False
            await asyncio.sleep(_POLL)
        return True

    def renew(self) -> None:
        """Become a new session (a new incarnation) on the same link: the platforms answer
        the newest session only, so a long-lived one displaced by a later ``gs`` command
        renews itself to be answered again (what is in flight is dropped)."""
        self.station.renew(session_incarnation())

    async def listen(self, seconds: float) -> None:
        """Just listen (heartbeats tell who is there) for ``seconds``."""
        await asyncio.sleep(seconds)

    def explain(self, targets: Collection[int], answered: Collection[int]) -> list[str]:
        """Why the ``targets`` not in ``answered`` did not answer, as far as this session
        can tell (:func:`actorswarm.ground.silence.explain`); empty when all answered."""
        station, guard = self.station, self.guard
        return explain(
            self.swarm,
            targets=targets,
            answered=answered,
            heard=station.heard,
            listed=station.listed,
            acked=station.acked,
            rejected=guard.rejected,
            refused_from=guard.refused_from,
        )
