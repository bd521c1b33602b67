"""The simulator as a swarm source: a :class:`~actorswarm.sim.tasksim.TaskSim` stepped in
virtual time, paced to the wall clock, in a background asyncio task.

Pacing: every wake, the wall time that passed times :attr:`SimSource.speed` is owed to the
simulation; it is paid in chunks of at most ``chunk`` virtual seconds — fewer for a swarm so
large that a chunk would take longer than ``budget`` wall seconds to simulate — for at most
``budget`` wall seconds before the event loop gets a turn, so the pages' connections stay
served however large the swarm. A simulation that cannot keep up simply runs as fast as
the machine allows: at most :data:`MAX_OWED` wall seconds of debt are kept, so it never
races to catch up, and the frames report the pace actually reached. The simulation never
reads a clock; this host does, between chunks — as ``actorswarm demo --realtime`` does.

The operator's commands go through the simulation's own ground station
(:attr:`TaskSim.ground`, platform 0) over the simulated radio, exactly as they would over
Zenoh. What the map shows — poses, actors, control blocks — is read from the simulated
platforms directly: a simulator sees everything, and polling status over the simulated
radio would only add traffic to the run.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Mapping
from typing import Any, Literal, TypeVar

from actorswarm.ground.station import GroundStation
from actorswarm.sim.tasksim import TaskSim
from actorswarm.web.operator import Timeouts
from actorswarm.web.source import PlatformRow, SwarmSource

__all__ = ["MAX_OWED", "SimSource"]

_T = TypeVar("_T")

#: Wall seconds of simulation a slow machine may owe before the debt is forgiven.
MAX_OWED = 0.5
#: The least virtual time stepped at once.
MIN_CHUNK = 0.002


class SimSource(SwarmSource):
    """``sim`` served to the page, ``speed`` virtual seconds per wall second, up to
    ``until`` virtual seconds (None: until the server stops)."""

    kind: Literal["sim", "real", "replay"] = "sim"

    def __init__(
        self,
        sim: TaskSim,
        *,
        title: str = "",
        sha: str = "",
        speed: float = 1.0,
        until: float | None = None,
        period: float = 0.02,
        chunk: float = 0.1,
        budget: float = 0.05,
        timeouts: Timeouts | None = None,
    ) -> None:
        if not 0 < speed <= 100:
            raise ValueError(f"speed must be > 0 and <= 100 (virtual s per wall s), not {speed}")
        self.sim = sim
        self.initial_sha = sha
        self._speed = speed
        self.until = until
        self.period = period
        self.chunk = chunk
        self.budget = budget
        #: The pace reached lately (virtual seconds per wall second).
        self.reached = 0.0
        # Wall seconds one virtual second costs to simulate (a running mean).
        self._cost = 0.0
        super().__init__(
            title=title or f"simulation of {sim.script.name}",
            script=sim.script,
            sha=sha,
            t_leave=sim.config.t_leave,
            timeouts=timeouts,
        )
        # A run that was advanced before it was served keeps its past on the timeline.
        self.timeline.add(sorted(sim.records, key=lambda r: (r["t"], r["platform"])))

    # --- hooks -------------------------------------------------------------------------

    def now(self) -> float:
        return self.sim.swarm.now

    @property
    def station(self) -> GroundStation:
        assert self.sim.ground is not None  # TaskSim always builds one
        return self.sim.ground

    def act(self, action: Callable[[GroundStation, float], _T]) -> _T:
        result: _T = self.sim.operate(action)  # type: ignore[assignment]
        return result

    def speed(self) -> float:
        return self._speed

    def set_speed(self, speed: float) -> str:
        if not 0 < speed <= 100:
            raise ValueError(f"the pace must be > 0 and <= 100, not {speed}")
        self._speed = speed
        return f"the simulation now runs at ×{speed:g}"

    def rows(self) -> list[PlatformRow]:
        sim = self.sim
        ids = sorted(set(sim.script.platform_ids()) | set(sim.hosts))
        world = sim.world
        rows = []
        if world is not None:
            fleet = world.fleet
            positions = fleet.positions.tolist()
            headings = fleet.headings.tolist()
            where = {p: i for i, p in enumerate(fleet.platforms)}
        for p in ids:
            host = sim.hosts.get(p)
            row = PlatformRow(
                platform=p,
                alive=host is not None,
                actors={} if host is None else host.engine.runtime.loaded(),
            )
            if world is not None and p in where:
                x, y, _ = positions[where[p]]
                row.x, row.y, row.heading = x, y, headings[where[p]]
            rows.append(row)
        return rows

    def acbs(self, platform: int) -> dict[str, Any] | None:
        host = self.sim.hosts.get(platform)
        return None if host is None else host.engine.runtime.status(self.now())

    def script_of(self, platform: int) -> str:
        host = self.sim.hosts.get(platform)
        if host is None:
            return ""
        # A platform started by the simulator runs the script it was given, not a deployed one.
        return host.engine.script_sha or self.initial_sha

    def vehicle_of(self, platform: int) -> Mapping[str, object]:
        # What a status reply would carry: the world's vehicles say nothing of themselves.
        host = self.sim.hosts.get(platform)
        return {} if host is None else host.engine.runtime.vehicle_state()

    def roles_of(self, platform: int) -> list[str]:
        # What a status reply would carry: the roles its core holds.
        host = self.sim.hosts.get(platform)
        return [] if host is None else sorted(host.engine.node.roles.held)

    def targets(self) -> list[dict[str, Any]]:
        if self.sim.world is None:
            return []
        return [
            {"name": name, "x": round(x, 1), "y": round(y, 1)}
            for name, (x, y, _) in self.sim.world.target_positions().items()
        ]

    def areas(self) -> dict[str, list[list[float]]]:
        if self.sim.world is None:
            return {}
        return {
            name: [[x, y] for x, y in polygon]
            for name, polygon in self.sim.world.area_polygons().items()
        }

    def area_names(self) -> list[str] | None:
        if self.sim.world is None:
            return None
        return list(self.sim.world.area_polygons())

    # --- stepping ------------------------------------------------------------------------

    def _chunk(self) -> float:
        """Virtual seconds to step at once: ``chunk``, or less for a swarm so large that
        a chunk would hold the event loop longer than ``budget`` (the pages' frames would
        stall)."""
        return max(MIN_CHUNK, min(self.chunk, self.budget / max(self._cost, 1e-9)))

    def ended(self) -> bool:
        return self.until is not None and self.sim.swarm.now >= self.until - 1e-9

    def step(self, seconds: float) -> None:
        """Advance the simulation by ``seconds`` of virtual time (at most to ``until``)
        and publish what happened."""
        target = self.sim.swarm.now + seconds
        if self.until is not None:
            target = min(target, self.until)
        self.record(self.sim.advance(target))
        self.pump()

    async def _run(self) -> None:
        clock = time.monotonic
        last = clock()
        owed = 0.0  # virtual seconds
        window_wall, window_virtual = last, self.now()
        while True:
            woke = clock()
            owed = min(owed + (woke - last) * self._speed, MAX_OWED * self._speed)
            last = woke
            while owed > 1e-6 and not self.ended() and clock() - woke < self.budget:
                seconds = min(owed, self._chunk())
                began = clock()
                self.step(seconds)
                self._cost = 0.8 * self._cost + 0.2 * (clock() - began) / seconds
                owed -= seconds
            if self.ended():
                owed = 0.0
                self.pump()
            self.look()
            if woke - window_wall >= 1.0:
                self.reached = (self.now() - window_virtual) / (woke - window_wall)
                window_wall, window_virtual = woke, self.now()
            # A turn for the connections; a short nap when the debt is paid.
            await asyncio.sleep(self.period if owed <= 1e-6 else 0)
