"""A real swarm as a swarm source: a ground-station session over Zenoh that polls status.

A :class:`RealSource` opens a :class:`~actorswarm.daemon.ground.GroundSession` (the same one
the ``actorswarm gs`` commands use, with their keys and endpoints) and keeps it open: the
platforms' heartbeats say who is there, which is master and in which epoch; every ``poll``
seconds it asks every platform heard for its :class:`~actorswarm.engine.commands.Status`,
whose reply carries the actors and their control blocks. Commands from the page go through
the same session.

Where the platforms are comes with their status replies (position and velocity, for
platforms with a vehicle; the map lays the others out by actor). What a real swarm does
not tell is when exactly each switch happened: the timeline's steps of a real swarm are
the changes between two status replies (cause ``observed``), as coarse as the polling.

Nor does a real swarm tell which world it flies in: given one (``world``, what ``gs web
--world`` reads), the map draws its areas and a script deployed from the page must name
only those areas, as ``actorswarm task check --world`` demands.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, Literal, TypeVar

from actorswarm.daemon.loop import clock
from actorswarm.dsl.model import TaskScript
from actorswarm.engine import commands as cmds
from actorswarm.ground.recorder import observed
from actorswarm.ground.station import GroundStation, ReplyRecord
from actorswarm.web.operator import Timeouts
from actorswarm.web.source import PlatformRow, SwarmSource

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.world.config import WorldConfig

__all__ = ["RealSource", "observed"]

_T = TypeVar("_T")

#: A platform that moved less than this (m) between two status replies shows no heading
#: (a hovering multicopter has none worth drawing).
_MOVED = 0.3


def _pose(
    status: cmds.StatusReply | None, before: list[float] | None
) -> tuple[float | None, float | None, float | None]:
    """x, y and heading (radians from east, counter-clockwise) from a status reply, the
    heading from the move since the ``before`` position (None when it barely moved); all
    None for a platform without a vehicle."""
    if status is None or status.position is None or len(status.position) < 2:
        return None, None, None
    x, y = status.position[0], status.position[1]
    heading = None
    if (
        before is not None
        and len(before) >= 2
        and math.hypot(x - before[0], y - before[1]) > _MOVED
    ):
        heading = math.atan2(y - before[1], x - before[0])
    return x, y, heading


class RealSource(SwarmSource):
    """The swarm reached by ``session`` (entered and left by this source)."""

    kind: Literal["sim", "real", "replay"] = "real"

    def __init__(
        self,
        session: GroundSession,
        *,
        title: str = "",
        script: TaskScript | None = None,
        sha: str = "",
        poll: float = 1.0,
        timeouts: Timeouts | None = None,
        world: WorldConfig | None = None,
    ) -> None:
        if poll <= 0:
            raise ValueError(f"poll must be > 0 seconds, not {poll}")
        self.session = session
        self.poll = poll
        self.world = world
        #: When the session started, on the station's clock (what the page counts from).
        self.t0 = clock()
        self._status: dict[int, cmds.StatusReply] = {}
        #: Each platform's position before its latest one (its heading on the map).
        self._before: dict[int, list[float] | None] = {}
        self._running: dict[int, tuple[str, ...]] = {}
        super().__init__(
            title=title or f"swarm {session.swarm!r} over Zenoh",
            script=script,
            sha=sha,
            t_leave=session.station.config.t_leave,
            timeouts=timeouts,
        )

    # --- hooks -------------------------------------------------------------------------

    def now(self) -> float:
        return clock()

    def origin(self) -> float:
        return self.t0

    @property
    def station(self) -> GroundStation:
        return self.session.station

    def act(self, action: Callable[[GroundStation, float], _T]) -> _T:
        return self.session.do(action)

    def rows(self) -> list[PlatformRow]:
        self.membership.update(self.station, self.now(), self.expected())
        rows = []
        for p, member in self.membership.members.items():
            status = self._status.get(p)
            x, y, heading = _pose(status, self._before.get(p))
            rows.append(
                PlatformRow(
                    platform=p,
                    alive=member.state == "joined",
                    x=x,
                    y=y,
                    heading=heading,
                    actors={} if status is None else dict(status.actors),
                )
            )
        return rows

    def acbs(self, platform: int) -> dict[str, Any] | None:
        status = self._status.get(platform)
        return None if status is None else dict(status.acbs)

    def script_of(self, platform: int) -> str:
        status = self._status.get(platform)
        return "" if status is None else status.script

    def vehicle_of(self, platform: int) -> Mapping[str, object]:
        status = self._status.get(platform)
        return {} if status is None else status.vehicle

    def roles_of(self, platform: int) -> list[str]:
        status = self._status.get(platform)
        return [] if status is None else sorted(status.roles)

    def areas(self) -> dict[str, list[list[float]]]:
        if self.world is None:
            return {}
        return {a.name: [[x, y] for x, y in a.polygon] for a in self.world.areas}

    def area_names(self) -> list[str] | None:
        return None if self.world is None else [a.name for a in self.world.areas]

    def on_reply(self, record: ReplyRecord) -> None:
        reply = record.reply
        if not isinstance(reply, cmds.StatusReply):
            return
        p = record.platform
        running = tuple(a for a, s in reply.actors.items() if s == "running")
        before = self._running.get(p)
        if before is not None and before != running:
            self.record(observed(record.t, p, before, running))
        self._running[p] = running
        previous = self._status.get(p)
        if previous is not None and previous.position != reply.position:
            self._before[p] = previous.position
        self._status[p] = reply

    # --- polling -------------------------------------------------------------------------

    def _ask_status(self, platforms: list[int]) -> None:
        if platforms:
            self.act(lambda st, now: st.send(cmds.Status(), platforms, now))

    async def _run(self) -> None:
        async with self.session:
            next_poll = clock() + min(self.poll, 1.0)  # heartbeats first: who is there
            while True:
                self.pump()
                self.look()
                if clock() >= next_poll:
                    self._ask_status(self._heard())
                    next_poll = clock() + self.poll
                await asyncio.sleep(0.05)
