"""The simulated world: the fleet, the targets, the areas and the radio model, in one clock.

Theory of operation
-------------------
A :class:`World` owns a :class:`~actorswarm.world.vehicles.Fleet` and advances it in fixed
steps of ``config.world.step`` seconds. The caller owns time: :meth:`World.step_to` runs
every whole step up to the time it is given (virtual seconds from the simulator's
scheduler; never the clock), so how often it is called changes nothing — stepping to 10 s
once or a hundred times on the way gives the same state. The world's time is a step count
times the step, not a running sum, so it does not drift over long runs.

Targets are functions of time (:mod:`actorswarm.world.targets`) and are asked at the
world's time. Areas are the configured polygons. :meth:`World.link` and
:meth:`World.link_matrix` apply the radio model (:mod:`actorswarm.world.radio_model`) to the
vehicles' current positions, for the simulated radio to use per packet. With the radio's
``relay`` on, :meth:`World.link` answers for the relayed path instead
(:func:`~actorswarm.world.radio_model.routes`), its routes worked out again every
:data:`ROUTE_INTERVAL` seconds of world time, as a link-state protocol's updates follow
the vehicles (every step would cost a millisecond a step at 30 platforms).
:meth:`World.hop_span` says how many hops the swarm spans now.

Recording: :meth:`World.record` snapshots every vehicle (and target) at the current time;
with ``record_every`` the world also does it by itself, at time 0 and then every that many
seconds of stepping. :meth:`World.track` stacks the snapshots into arrays (a
:class:`Track`) for trajectory pictures; :meth:`Track.rows` gives the same as flat rows.
A snapshot is a few array copies, so recording every step of 300 vehicles stays cheap.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import NoReturn

import numpy as np
from numpy.typing import NDArray

from actorswarm.world import radio_model
from actorswarm.world.config import Area, WorldConfig
from actorswarm.world.sensors import SimCamera
from actorswarm.world.targets import Targets
from actorswarm.world.vehicles import MODES, Fleet, Mode, SimVehicle

__all__ = ["ROUTE_INTERVAL", "Track", "World"]

FloatArray = NDArray[np.float64]
# A time this close above a step boundary counts as the boundary: 0.1 + 0.2 is 0.3.
_SLACK = 1e-9

#: Seconds of world time between two computations of the relayed routes (radio ``relay``).
ROUTE_INTERVAL = 0.5

# World.link's cache: (step count, (loss row, latency row) by sender, (forwarders, hops
# row) by sender when the radio relays).
_Links = tuple[int, dict[int, tuple[list[float], list[float]]], dict[int, tuple[int, list[int]]]]


@dataclass(frozen=True, slots=True)
class Track:
    """Recorded snapshots, as arrays: ``m`` snapshots of ``n`` vehicles and ``k`` targets.

    ``times`` ``(m,)``; ``platforms`` ``(n,)``; ``positions`` ``(m, n, 3)``; ``headings``
    ``(m, n)`` radians; ``modes`` ``(m, n)`` codes into :data:`~actorswarm.world.vehicles.
    MODES`; ``batteries`` ``(m, n)``; ``target_names`` ``(k,)`` and ``target_positions``
    ``(m, k, 3)``; ``goals`` ``(m, n, 3)``, where each vehicle was told to be
    (:attr:`~actorswarm.world.vehicles.Fleet.goals`: a formation's slots).
    """

    times: FloatArray
    platforms: NDArray[np.int64]
    positions: FloatArray
    headings: FloatArray
    modes: NDArray[np.int8]
    batteries: FloatArray
    target_names: tuple[str, ...]
    target_positions: FloatArray
    goals: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 3)))

    def __len__(self) -> int:
        return len(self.times)

    def rows(self) -> Iterator[tuple[float, int, float, float, float, float, Mode]]:
        """``(t, platform, x, y, z, heading, mode)`` per snapshot and vehicle, in time then
        platform order."""
        for i, t in enumerate(self.times.tolist()):
            pos = self.positions[i].tolist()
            headings = self.headings[i].tolist()
            modes = self.modes[i].tolist()
            for j, platform in enumerate(self.platforms.tolist()):
                x, y, z = pos[j]
                yield (t, platform, x, y, z, headings[j], MODES[modes[j]])

    def target_rows(self) -> Iterator[tuple[float, str, float, float, float]]:
        """``(t, name, x, y, z)`` per snapshot and target, in time then file order."""
        for i, t in enumerate(self.times.tolist()):
            for name, (x, y, z) in zip(
                self.target_names, self.target_positions[i].tolist(), strict=True
            ):
                yield (t, name, x, y, z)

    def of(self, platform: int) -> FloatArray:
        """``(m, 3)``: the trajectory of ``platform``."""
        where = np.flatnonzero(self.platforms == platform)
        if not where.size:
            raise KeyError(f"platform {platform!r} is not in the track")
        out: FloatArray = self.positions[:, int(where[0]), :]
        return out


class World:
    """Vehicles, targets, areas and radio model of one simulation (module docstring).

    ``platforms``: the run's platform IDs (None: the world file's ``fleet.platforms``).
    ``record_every``: record a snapshot every that many seconds of stepping, and one at
    time 0 (None: only when :meth:`record` is called).
    """

    def __init__(
        self,
        config: WorldConfig,
        platforms: Iterable[int] | None = None,
        *,
        record_every: float | None = None,
    ) -> None:
        self.config = config
        self.fleet = Fleet.from_config(config, platforms)
        self.targets = Targets(config.targets)
        self.areas: Mapping[str, Area] = {area.name: area for area in config.areas}
        self._step = config.world.step
        self._steps = 0
        self._asked = 0.0
        self._snapshots: list[
            tuple[
                float, FloatArray, FloatArray, NDArray[np.int8], FloatArray, FloatArray, FloatArray
            ]
        ] = []
        self._record_stride = 0
        # The radio model over the current positions, as (step count, each sender's (loss
        # row, latency row) by platform, and with relays each sender's (forwarders, hops
        # row)): positions change only on a step, and the simulated radio asks once per
        # packet and receiver.
        self._links: _Links | None = None
        # Each platform's row (the fleet's, which never changes), read without a call.
        self._rows: dict[int, int] = {p: row for row, p in enumerate(self.fleet.platforms)}
        if record_every is not None:
            if not (math.isfinite(record_every) and record_every > 0):
                raise ValueError(
                    f"record_every must be a number of seconds > 0, not {record_every!r}"
                )
            self._record_stride = max(1, round(record_every / self._step))
            self.record()

    def __repr__(self) -> str:
        return (
            f"World(t={self.time:.3f}, vehicles={len(self.fleet)}, targets={len(self.targets)}, "
            f"areas={len(self.areas)}, source={self.config.source!r})"
        )

    @property
    def time(self) -> float:
        """The world's time, seconds: the last step boundary reached."""
        return self._steps * self._step

    @property
    def step(self) -> float:
        """The physics step, seconds."""
        return self._step

    @property
    def platforms(self) -> tuple[int, ...]:
        """The platform IDs, ascending."""
        return self.fleet.platforms

    def step_to(self, t: float) -> None:
        """Advance by whole steps to the last step boundary at or before ``t`` seconds.

        ``t`` never goes back: asking for an earlier time than before raises ValueError (a
        time between the last boundary and the next does nothing until a later call
        crosses the boundary).
        """
        if not math.isfinite(t):
            raise ValueError(f"step_to: t must be a finite number of seconds, not {t!r}")
        if t < self._asked:
            raise ValueError(
                f"step_to({t!r}): the world is already at {self._asked!r} s; time runs forward"
            )
        self._asked = t
        target = math.floor(t / self._step + _SLACK)
        stride = self._record_stride
        while self._steps < target:
            self.fleet.step(self._step)
            self._steps += 1
            if stride and self._steps % stride == 0:
                self.record()

    def vehicle(self, platform: int) -> SimVehicle:
        """The :class:`~actorswarm.runtime.context.Vehicle` of ``platform``."""
        return self.fleet.vehicle(platform)

    def positions(self) -> dict[int, tuple[float, float, float]]:
        """Each platform's position now."""
        return {
            pid: (p[0], p[1], p[2])
            for pid, p in zip(self.fleet.platforms, self.fleet.positions.tolist(), strict=True)
        }

    def target_positions(self) -> dict[str, tuple[float, float, float]]:
        """Each target's position now, by name."""
        return self.targets.at(self.time)

    def area(self, name: str) -> Area:
        """The area called ``name``; KeyError with a suggestion when there is none."""
        return self.config.area(name)

    def area_polygons(self) -> dict[str, tuple[tuple[float, float], ...]]:
        """Every area's polygon by name (what the plugins' ``ctx.areas`` holds)."""
        return {name: area.polygon for name, area in self.areas.items()}

    def camera(self, platform: int) -> SimCamera:
        """The :class:`~actorswarm.runtime.context.Camera` of ``platform``'s vehicle."""
        return SimCamera(self, platform)

    def wrecked(self) -> list[int]:
        """The platforms whose vehicle died (battery empty) and has hit the ground: the
        robot and its radio are gone."""
        fleet = self.fleet
        dead = (fleet.modes == MODES.index("dead")) & (fleet.positions[:, 2] <= 0.0)
        return [fleet.platforms[int(i)] for i in np.flatnonzero(dead)]

    # --- radio -----------------------------------------------------------------------------------

    def link(self, a: int, b: int) -> tuple[float, float]:
        """``(loss_probability, latency_s)`` between platforms ``a`` and ``b`` now.

        The whole matrix is computed once per physics step, on the first question of that
        step, since the radio asks once per packet (thousands of times a second) while the
        positions change only when the world steps. KeyError for an unknown platform."""
        links = self._links
        if links is None or links[0] != self._steps:  # _current_links, inlined: per packet
            links = self._links = self._link_rows(links)
        try:
            loss_row, latency_row = links[1][a]
            j = self._rows[b]
        except KeyError:
            self._unknown(a, b)
        return loss_row[j], latency_row[j]

    def relays(self, a: int, b: int | None) -> int:
        """How many times relays send on a packet from ``a`` to ``b`` now (None: a broadcast
        to everyone): with the radio's ``relay``, a unicast's relays on its path and a
        broadcast's forwarders (:class:`~actorswarm.world.radio_model.Routes`); 0 without
        relaying, or where no path exists. What the packet costs the shared air beyond its
        own transmission. KeyError for an unknown platform."""
        links = self._current_links()
        rows = self._rows
        if a not in rows or (b is not None and b not in rows):
            self._unknown(a, a if b is None else b)
        relayed = links[2].get(a)
        if relayed is None:
            return 0
        forwarders, hops_row = relayed
        return forwarders if b is None else max(hops_row[rows[b]] - 1, 0)

    def _current_links(self) -> _Links:
        """The link rows of the current step, made on the first question of the step."""
        links = self._links
        if links is None or links[0] != self._steps:
            links = self._links = self._link_rows(links)
        return links

    def _unknown(self, a: int, b: int) -> NoReturn:
        """Raise the fleet's KeyError, which names the platforms it has, for whichever of
        ``a`` and ``b`` it does not have."""
        self.fleet.index(a)
        self.fleet.index(b)
        raise KeyError((a, b))

    def _link_rows(self, last: _Links | None) -> _Links:
        """The link rows of this step: the radio model's, or with ``relay`` the routes',
        kept from ``last`` until :data:`ROUTE_INTERVAL` has passed since they were made."""
        radio = self.config.radio
        if radio.relay and last is not None:
            every = max(1, round(ROUTE_INTERVAL / self._step))
            if self._steps // every == last[0] // every:
                return self._steps, last[1], last[2]
        loss, latency = radio_model.link_matrix(self.fleet.positions, radio)
        platforms = self.fleet.platforms
        relayed: dict[int, tuple[int, list[int]]] = {}
        if radio.relay:
            routed = radio_model.routes(loss, latency, radio.relay_latency)
            loss, latency = routed.loss, routed.latency
            relayed = dict(
                zip(
                    platforms,
                    zip(routed.forwarders.tolist(), routed.hops.tolist(), strict=True),
                    strict=True,
                )
            )
        rows = zip(loss.tolist(), latency.tolist(), strict=True)
        return self._steps, dict(zip(platforms, rows, strict=True)), relayed

    def hop_span(self) -> tuple[int, int]:
        """``(span, groups)`` now (:func:`~actorswarm.world.radio_model.hop_span`): the most
        radio hops between two platforms that reach each other, and how many groups out of
        each other's reach the swarm is in."""
        return radio_model.hop_span(self.fleet.positions, self.config.radio)

    def link_matrix(self) -> tuple[FloatArray, FloatArray]:
        """``(loss, latency)`` between every pair of platforms now, ``(n, n)`` in
        :attr:`platforms` order."""
        return radio_model.link_matrix(self.fleet.positions, self.config.radio)

    def reachable(self) -> NDArray[np.bool_]:
        """``(n, n)``: which platforms can hear each other now, in :attr:`platforms` order."""
        return radio_model.reachable(self.fleet.positions, self.config.radio)

    # --- recording -------------------------------------------------------------------------------

    def record(self) -> None:
        """Snapshot every vehicle and target at the current time."""
        fleet, t = self.fleet, self.time
        self._snapshots.append(
            (
                t,
                fleet.positions.copy(),
                fleet.headings.copy(),
                fleet.modes.copy(),
                fleet.batteries.copy(),
                self.targets.positions(t),
                fleet.goals.copy(),
            )
        )

    def track(self) -> Track:
        """Everything recorded so far, stacked (empty arrays when nothing was)."""
        n, k = len(self.fleet), len(self.targets)
        snaps = self._snapshots
        if not snaps:
            return Track(
                times=np.zeros(0),
                platforms=np.asarray(self.fleet.platforms, dtype=np.int64),
                positions=np.zeros((0, n, 3)),
                headings=np.zeros((0, n)),
                modes=np.zeros((0, n), dtype=np.int8),
                batteries=np.zeros((0, n)),
                target_names=self.targets.names,
                target_positions=np.zeros((0, k, 3)),
                goals=np.zeros((0, n, 3)),
            )
        return Track(
            times=np.array([s[0] for s in snaps]),
            platforms=np.asarray(self.fleet.platforms, dtype=np.int64),
            positions=np.stack([s[1] for s in snaps]),
            headings=np.stack([s[2] for s in snaps]),
            modes=np.stack([s[3] for s in snaps]),
            batteries=np.stack([s[4] for s in snaps]),
            target_names=self.targets.names,
            target_positions=np.stack([s[5] for s in snaps]),
            goals=np.stack([s[6] for s in snaps]),
        )
