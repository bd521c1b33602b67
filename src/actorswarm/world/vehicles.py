"""Vehicle physics for the whole fleet at once, and the per-platform :class:`SimVehicle`.

Theory of operation
-------------------
:class:`Fleet` holds the state of every vehicle in numpy arrays — position, velocity,
heading, airspeed, battery, mode — plus what the commands asked for (the point each vehicle
aims at, its goal after take-off, its commanded speed) and each vehicle's performance
limits, copied per vehicle so that quadrotors and fixed-wings of any performance advance
together. :meth:`Fleet.step` moves everyone by ``dt`` seconds with a few dozen array
operations, whatever the size of the fleet. There is no randomness and no clock: the same
commands at the same steps give the same trajectories, bit for bit.

A :class:`SimVehicle` is a thin handle on one row, implementing
:class:`~actorswarm.runtime.context.Vehicle`: its commands only write the command arrays and
return; the next :meth:`Fleet.step` acts on them.

Modes (:data:`MODES`)::

    ground --takeoff/goto--> takeoff --altitude reached--> flying --land--> landing --> landed
                                                                                         |
    any airborne mode --battery empty--> dead (falls)      landed --takeoff/goto--> takeoff

The frame is ENU (x east, y north, z up, metres); the ground is the plane z = 0 (no terrain,
no collisions between vehicles). A heading is in radians, counter-clockwise from east.
"Speed" is the magnitude of the 3-D velocity.

Quadrotor
    Flies in a straight line towards the point it aims at. The wanted speed is the
    commanded speed, reduced near the point so that it can brake at 80 % of ``max_accel``
    (the margin absorbs the discrete step) and so that one step never overshoots; the
    wanted velocity is then scaled down, keeping its direction, until its vertical part is
    within ``max_climb``. The velocity moves towards the wanted one by at most
    ``max_accel · dt``. Because the new velocity lies between the old and the wanted one,
    and both respect the speed and climb limits, so does the new one. At the point it
    hovers. Its heading follows the horizontal velocity (yaw is not modelled otherwise).
    Take-off is a vertical climb, landing a descent onto the point below it.

Fixed-wing
    By default ArduPlane 4.5.7 as measured in SITL (:class:`~actorswarm.world.config.
    FixedWingParams`; ``tests/world/test_fixedwing_conformance.py`` holds the model to the
    firmware's figures). Keeps an airspeed S in [min_airspeed, max_speed] once airborne,
    changed by at most ``max_accel · dt`` per step; a vertical speed within ``max_climb``
    (changed by at most ``max_accel · dt``, and with ``climb_gain`` at most that many times
    the height still to go), the rest of S being horizontal along the heading; and a
    heading that turns by at most ``max_turn_rate · dt``. It steers by a guidance vector
    field around the point it aims at (Lawrence, Frew & Pisano, 2008): with r the
    horizontal distance to the point and R the loiter radius, the wanted direction is::

        -(r² - R²) / (r² + R²) · r̂  ±  2 r R / (r² + R²) · t̂       (t̂: counter-clockwise)

    a unit vector that becomes the circle's tangent at r = R, so "fly to the goal" and
    "circle the goal" are one law and the aircraft never stops: it arrives by spiralling
    onto the circle of radius R around its goal and loiters there (clockwise, ArduPlane's
    way, unless ``loiter_clockwise`` is false) until told otherwise. R is at least S over
    the turn rate: a circle tighter than the aircraft can turn at its speed is flown as
    tight as it can. The field alone still points 28° off the goal at r = 4R, which would
    make an aircraft chasing a moving goal (a formation slot) drift sideways for ever; so
    beyond 2R the wanted direction turns from the field's towards the straight bearing to
    the goal, reaching it at 3R (pure pursuit from afar, as an autopilot flies to a waypoint
    before it loiters there). ``hold`` makes the current position the goal. Take-off rolls
    along the runway (the heading at home), accelerating at ``max_accel``, lifts off at
    ``rotate_speed`` and climbs straight ahead; from ``level_altitude`` up it turns
    towards the point ``takeoff_distance`` down the runway (ArduPlane's ``TKOFF_DIST``),
    or the goal of a ``goto`` given meanwhile, and circles it at the take-off altitude
    (with no take-off distance it climbs straight to its altitude and circles where it got
    there). Landing keeps the heading,
    slows to ``landing_speed``, descends at up to ``max_climb`` (flaring near the ground),
    touches down and brakes to a stop: it lands ahead of where it was told, as an aircraft
    does; ``land_at`` glides to a point at ``glide_slope`` instead.

Battery
    Every airborne mode drains ``p(speed) / (p(cruise) · endurance)`` per second, with
    ``p(s) = rest_power + (1 - rest_power) · s / max_speed``; a vehicle on the ground draws
    nothing. A vehicle whose battery reaches 0 is ``dead``: it falls ballistically (its
    velocity kept, gravity added) to the ground, stays there, and ignores every command.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any, Final, Literal, TypeVar, get_args

import numpy as np
from numpy.typing import NDArray

from actorswarm.world.config import (
    FixedWingParams,
    Kind,
    VehicleSpec,
    WorldConfig,
)

__all__ = [
    "DEAD",
    "FLYING",
    "GROUND",
    "LANDED",
    "LANDING",
    "MODES",
    "TAKEOFF",
    "Fleet",
    "Mode",
    "SimVehicle",
]

Mode = Literal["ground", "takeoff", "flying", "landing", "landed", "dead"]
#: Mode names, indexed by the codes in :attr:`Fleet.modes`.
MODES: Final[tuple[Mode, ...]] = get_args(Mode)
GROUND: Final = 0
TAKEOFF: Final = 1
FLYING: Final = 2
LANDING: Final = 3
LANDED: Final = 4
DEAD: Final = 5

FloatArray = NDArray[np.float64]
_A = TypeVar("_A", bound=np.ndarray[Any, Any])

GRAVITY: Final = 9.81
# Share of max_accel planned for braking: the discrete step brakes a little late, and the
# margin keeps the vehicle from overshooting its point.
_BRAKE: Final = 0.8
# Take-off altitude reached / touched down within this many metres.
_ARRIVE: Final = 0.05
# Below this horizontal speed a quadrotor's heading stays where it was.
_HEADING_SPEED: Final = 0.5


class Fleet:
    """Every simulated vehicle of a world, advanced together by :meth:`step`.

    Build it from resolved :class:`~actorswarm.world.config.VehicleSpec` s (or with
    :meth:`from_config`); every vehicle starts on the ground at its home, facing its heading,
    in mode ``ground``. Rows are in the order of the specs; :attr:`platforms` maps rows to
    platform IDs.

    The state arrays (:attr:`positions`, :attr:`velocities`, :attr:`headings`,
    :attr:`airspeeds`, :attr:`batteries`, :attr:`modes`) are read-only views of the live
    state: they change with every step; copy what you keep.
    """

    def __init__(self, specs: Sequence[VehicleSpec]) -> None:
        self._platforms = tuple(spec.platform for spec in specs)
        if len(set(self._platforms)) != len(self._platforms):
            raise ValueError(f"a platform appears twice among {self._platforms}")
        self._index = {pid: row for row, pid in enumerate(self._platforms)}
        self._kinds: tuple[Kind, ...] = tuple(spec.kind for spec in specs)
        n = len(specs)

        def column(values: Iterable[float]) -> FloatArray:
            return np.fromiter(values, dtype=np.float64, count=n)

        fixed = [
            spec.params if isinstance(spec.params, FixedWingParams) else None for spec in specs
        ]
        params = [spec.params for spec in specs]
        self._is_fw = np.array([p is not None for p in fixed], dtype=bool)
        self._max_speed = column(p.max_speed for p in params)
        self._cruise = column(p.cruise_speed for p in params)
        self._accel = column(p.max_accel for p in params)
        self._climb = column(p.max_climb for p in params)
        self._min_speed = column(f.min_airspeed if f else 0.0 for f in fixed)
        self._turn = column(f.turn_rate_rad if f else math.inf for f in fixed)
        self._loiter = column(f.loiter_radius if f else 0.0 for f in fixed)
        self._loiter_dir = column(-1.0 if f and f.loiter_clockwise else 1.0 for f in fixed)
        self._rotate = column(max(f.min_airspeed, f.rotate_speed) if f else 0.0 for f in fixed)
        self._level = column(
            f.level_altitude if f and f.level_altitude > 0 else math.inf for f in fixed
        )
        self._climb_gain = column(f.climb_gain if f else 0.0 for f in fixed)
        self._takeoff_dist = column(f.takeoff_distance if f else 0.0 for f in fixed)
        self._glide = column(math.tan(math.radians(f.glide_slope)) if f else 0.0 for f in fixed)
        self._land_speed = column((f.landing_speed or f.min_airspeed) if f else 0.0 for f in fixed)
        rest = column(p.rest_power for p in params)
        self._rest = rest
        # Drain per second at speed s is (rest + (1 - rest) s / max) * _drain_scale, so that
        # a full battery lasts `endurance` seconds at cruise speed.
        cruise_power = rest + (1.0 - rest) * self._cruise / self._max_speed
        self._drain_scale = 1.0 / (cruise_power * column(p.endurance for p in params))

        self._pos = np.zeros((n, 3))
        self._pos[:, 0] = column(spec.home[0] for spec in specs)
        self._pos[:, 1] = column(spec.home[1] for spec in specs)
        self._home = self._pos.copy()  # where each vehicle started: its home
        self._vel = np.zeros((n, 3))
        self._heading = column(spec.heading for spec in specs)
        self._airspeed = np.zeros(n)
        self._battery = column(spec.battery for spec in specs)
        self._mode = np.full(n, GROUND, dtype=np.int8)
        # Commands: the point each vehicle steers to now, its goal once the take-off is over
        # (when _pending), the speed asked for, the take-off altitude.
        self._aim = self._pos.copy()
        self._goal = self._pos.copy()
        self._pending = np.zeros(n, dtype=bool)
        self._speed_cmd = self._cruise.copy()
        self._takeoff_alt = np.zeros(n)
        # A landing to a point (land_at): the glide's tangent (0: none), the distance short
        # of the point where it meets the ground, and the altitude it starts from.
        self._glide_tan = np.zeros(n)
        self._glide_short = np.zeros(n)
        self._glide_top = np.zeros(n)
        self._vehicles = [SimVehicle(self, row) for row in range(n)]

    @classmethod
    def from_config(cls, config: WorldConfig, platforms: Iterable[int] | None = None) -> Fleet:
        """The fleet of ``config`` for ``platforms`` (None: the world's own list)."""
        return cls(config.vehicle_specs(platforms))

    # --- reading ---------------------------------------------------------------------------------

    def __len__(self) -> int:
        return len(self._platforms)

    @property
    def platforms(self) -> tuple[int, ...]:
        """The platform ID of each row."""
        return self._platforms

    @property
    def kinds(self) -> tuple[Kind, ...]:
        """The vehicle kind of each row."""
        return self._kinds

    def index(self, platform: int) -> int:
        """The row of ``platform``; KeyError when the fleet has no such platform."""
        try:
            return self._index[platform]
        except KeyError:
            raise KeyError(
                f"no vehicle for platform {platform!r}; the fleet has platforms "
                f"{_span(self._platforms)}"
            ) from None

    def vehicle(self, platform: int) -> SimVehicle:
        """The handle on ``platform``'s vehicle (the same object every time)."""
        return self._vehicles[self.index(platform)]

    def mode(self, platform: int) -> Mode:
        """The mode of ``platform``'s vehicle."""
        return MODES[int(self._mode[self.index(platform)])]

    @property
    def positions(self) -> FloatArray:
        """``(n, 3)`` positions, metres."""
        return _readonly(self._pos)

    @property
    def goals(self) -> FloatArray:
        """``(n, 3)`` where each vehicle is told to be: a goto's point (a formation slot, the
        search pattern's next leg), the point it holds; its position until told anything."""
        return _readonly(self._goal)

    @property
    def velocities(self) -> FloatArray:
        """``(n, 3)`` velocities, m/s."""
        return _readonly(self._vel)

    @property
    def headings(self) -> FloatArray:
        """``(n,)`` headings, radians counter-clockwise from east, in (-π, π]."""
        return _readonly(self._heading)

    @property
    def airspeeds(self) -> FloatArray:
        """``(n,)`` speeds (magnitude of the velocity), m/s."""
        return _readonly(self._airspeed)

    @property
    def batteries(self) -> FloatArray:
        """``(n,)`` charge left, 0..1."""
        return _readonly(self._battery)

    @property
    def modes(self) -> NDArray[np.int8]:
        """``(n,)`` mode codes, indices into :data:`MODES`."""
        return _readonly(self._mode)

    @property
    def fixed_wing(self) -> NDArray[np.bool_]:
        """``(n,)`` True for the fixed-wing rows."""
        return _readonly(self._is_fw)

    # --- physics ---------------------------------------------------------------------------------

    def step(self, dt: float) -> None:
        """Advance every vehicle by ``dt`` seconds (> 0)."""
        if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"step: dt must be a finite number of seconds > 0, not {dt!r}")
        mode = self._mode
        airborne = (mode == TAKEOFF) | (mode == FLYING) | (mode == LANDING)
        falling = (mode == DEAD) & ((self._pos[:, 2] > 0.0) | (self._vel[:, 2] != 0.0))
        quad = np.flatnonzero(airborne & ~self._is_fw)
        fixed = np.flatnonzero(airborne & self._is_fw)
        if quad.size:
            self._step_quadrotors(quad, dt)
        if fixed.size:
            self._step_fixed_wings(fixed, dt)
        if falling.any():
            self._fall(np.flatnonzero(falling), dt)
        if airborne.any():
            self._drain(np.flatnonzero(airborne), dt)

    def _step_quadrotors(self, rows: NDArray[np.intp], dt: float) -> None:
        pos, vel, aim = self._pos[rows], self._vel[rows], self._aim[rows]
        before = vel
        accel, climb = self._accel[rows], self._climb[rows]
        mode = self._mode[rows]
        delta = aim - pos
        dist = np.linalg.norm(delta, axis=1)
        # Take-off and landing are vertical: their speed is the climb limit's to set.
        cap = np.where(mode == FLYING, self._speed_cmd[rows], self._max_speed[rows])
        want = np.minimum(np.minimum(cap, _braking_speed(dist, _BRAKE * accel, dt)), dist / dt)
        unit = delta / np.where(dist > 0.0, dist, 1.0)[:, None]
        wanted = unit * want[:, None]
        # Scale the whole vector (not just its z) so that the path stays a straight line.
        vz = np.abs(wanted[:, 2])
        wanted *= np.where(vz > climb, climb / np.where(vz > 0.0, vz, 1.0), 1.0)[:, None]
        change = wanted - vel
        size = np.linalg.norm(change, axis=1)
        limit = accel * dt
        vel = vel + change * np.where(size > limit, limit / np.where(size > 0, size, 1), 1)[:, None]
        pos = pos + vel * dt
        pos[:, 2] = np.maximum(pos[:, 2], 0.0)
        horizontal = np.hypot(vel[:, 0], vel[:, 1])
        heading = np.where(
            horizontal > _HEADING_SPEED, np.arctan2(vel[:, 1], vel[:, 0]), self._heading[rows]
        )
        self._pos[rows], self._vel[rows], self._heading[rows] = pos, vel, heading
        self._airspeed[rows] = np.linalg.norm(vel, axis=1)
        self._finish_phases(rows, pos, before, dt)

    def _step_fixed_wings(self, rows: NDArray[np.intp], dt: float) -> None:
        pos, aim, mode = self._pos[rows], self._aim[rows], self._mode[rows]
        before = self._vel[rows]
        speed, heading, vz = self._airspeed[rows], self._heading[rows], self._vel[rows, 2]
        accel, climb = self._accel[rows], self._climb[rows]
        min_speed, max_speed = self._min_speed[rows], self._max_speed[rows]
        z = pos[:, 2]
        flying, takeoff, landing = mode == FLYING, mode == TAKEOFF, mode == LANDING

        # Heading: the guidance field when flying; take-off and landing hold the runway.
        rel = pos[:, :2] - aim[:, :2]
        r = np.hypot(rel[:, 0], rel[:, 1])
        away = r > 1e-9
        safe_r = np.where(away, r, 1.0)
        # Right over the point the radial direction is undefined: carry straight on.
        rx = np.where(away, rel[:, 0] / safe_r, np.cos(heading))
        ry = np.where(away, rel[:, 1] / safe_r, np.sin(heading))
        # A circle tighter than the aircraft can turn at its speed is flown wider, at the
        # tightest it can (a real autopilot's at its bank limit); the guidance field needs
        # the wider radius too, or it weaves in and out of a circle it cannot hold.
        radius = np.maximum(self._loiter[rows], speed / self._turn[rows])
        r2, big_r2 = r * r, radius * radius
        inward = -(r2 - big_r2) / (r2 + big_r2)
        along = 2.0 * r * radius / (r2 + big_r2) * self._loiter_dir[rows]
        fx, fy = inward * rx - along * ry, inward * ry + along * rx
        # Beyond 2R blend towards the straight bearing (-r̂), all of it from 3R (docstring).
        pursuit = np.clip(r / np.maximum(radius, 1e-9) - 2.0, 0.0, 1.0)
        fx = (1.0 - pursuit) * fx - pursuit * rx
        fy = (1.0 - pursuit) * fy - pursuit * ry
        field = np.arctan2(fy, fx)
        on_ground = z <= 0.0
        # A landing to a point steers straight at it until the wheels are down.
        glide_tan = self._glide_tan[rows]
        gliding = landing & (glide_tan > 0.0) & ~on_ground
        wanted_heading = np.where(flying, field, np.where(gliding, np.arctan2(-ry, -rx), heading))
        turn = _wrap(wanted_heading - heading)
        limit = self._turn[rows] * dt
        heading = _wrap(heading + np.clip(turn, -limit, limit))

        # Airspeed: what was asked when flying; cruise on the take-off roll; min_airspeed on
        # the approach, then braking to a stop once the wheels are down.
        wanted_speed = np.where(
            flying,
            np.clip(self._speed_cmd[rows], min_speed, max_speed),
            np.where(takeoff, self._cruise[rows], np.where(on_ground, 0.0, self._land_speed[rows])),
        )
        step = accel * dt
        speed = speed + np.clip(wanted_speed - speed, -step, step)

        # Vertical: towards the aim's altitude (the take-off altitude, the ground when
        # landing), braking in time. A take-off lifts off only at min_airspeed.
        lifted = ~takeoff | (z > 0.0) | (speed >= self._rotate[rows])
        target_z = np.where(landing, 0.0, np.where(takeoff, self._takeoff_alt[rows], aim[:, 2]))
        dz = target_z - z
        rate = np.minimum(
            np.minimum(climb, _braking_speed(np.abs(dz), _BRAKE * accel, dt)), np.abs(dz) / dt
        )
        gain = self._climb_gain[rows]
        rate = np.where(gain > 0.0, np.minimum(rate, gain * np.abs(dz)), rate)
        wanted_vz = np.where(lifted & ~(landing & on_ground), np.sign(dz) * rate, 0.0)
        if gliding.any():
            wanted_vz = np.where(gliding, self._glide_vz(rows, r, speed, z, wanted_vz), wanted_vz)
        vz = vz + np.clip(wanted_vz - vz, -step, step)

        horizontal = np.sqrt(np.maximum(speed * speed - vz * vz, 0.0))
        vel = np.stack((horizontal * np.cos(heading), horizontal * np.sin(heading), vz), axis=1)
        pos = pos + vel * dt
        # The descent profiles end at the ground at rest; this only absorbs rounding.
        pos[:, 2] = np.maximum(pos[:, 2], 0.0)
        self._pos[rows], self._vel[rows] = pos, vel
        self._heading[rows], self._airspeed[rows] = heading, speed
        self._finish_phases(rows, pos, before, dt)

    def _glide_vz(
        self,
        rows: NDArray[np.intp],
        r: FloatArray,
        speed: FloatArray,
        z: FloatArray,
        plain: FloatArray,
    ) -> FloatArray:
        """The vertical speed that follows a landing's glide line (``land_at``): the line's
        own sink plus a correction towards it (``climb_gain``, 1/s when unset); once the
        line has reached the ground (``r`` within its distance short of the point), the
        ``plain`` descent onto it."""
        tan, short, top = self._glide_tan[rows], self._glide_short[rows], self._glide_top[rows]
        line = np.minimum(top, tan * np.maximum(r - short, 0.0))
        sink = np.where((line > 0.0) & (line < top), speed * np.sin(np.arctan(tan)), 0.0)
        gain = np.where(self._climb_gain[rows] > 0.0, self._climb_gain[rows], 1.0)
        climb = self._climb[rows]
        follow = np.clip(-sink + gain * (line - z), -climb, climb)
        out: FloatArray = np.where(line > 0.0, follow, plain)
        return out

    def _finish_phases(
        self, rows: NDArray[np.intp], pos: FloatArray, before: FloatArray, dt: float
    ) -> None:
        """Mode changes at the end of a step: take-offs that reached their altitude fly on,
        landings that reached the ground (and, for a fixed-wing, stopped) are landed."""
        mode = self._mode[rows]
        z = pos[:, 2]
        # Handed over early at level_altitude only to turn towards a goal given meanwhile:
        # with none, it climbs straight ahead to its altitude.
        up = (mode == TAKEOFF) & (
            (np.abs(z - self._takeoff_alt[rows]) <= _ARRIVE)
            | ((z >= self._level[rows]) & self._pending[rows])
        )
        if up.any():
            done = rows[up]
            self._mode[done] = FLYING
            pending = self._pending[done]
            # No goto meanwhile: hover (circle) where the climb ended.
            self._aim[done] = np.where(pending[:, None], self._goal[done], self._pos[done])
            self._pending[done] = False
        # Touchdown within _ARRIVE of the ground, once it came down so slowly vertically (a
        # quadrotor: in every direction) that stopping dead in this step stays within
        # max_accel: the descent profile ends at the ground at rest, so this comes within a
        # few steps. (`before`: the velocity at the start of the step.)
        gentle = np.where(self._is_fw[rows], np.abs(before[:, 2]), np.linalg.norm(before, axis=1))
        down = (mode == LANDING) & (z <= _ARRIVE) & (gentle <= self._accel[rows] * dt)
        if down.any():
            done = rows[down]
            self._pos[done, 2] = 0.0
            self._vel[done, 2] = 0.0
            # A fixed-wing rolls on until it has braked to a stop.
            stopped = ~self._is_fw[done] | (self._airspeed[done] <= 0.0)
            finished = done[stopped]
            self._mode[finished] = LANDED
            self._vel[finished] = 0.0
            self._airspeed[finished] = 0.0

    def _fall(self, rows: NDArray[np.intp], dt: float) -> None:
        vel = self._vel[rows]
        vel[:, 2] -= GRAVITY * dt
        pos = self._pos[rows] + vel * dt
        down = pos[:, 2] <= 0.0
        pos[down, 2] = 0.0
        vel[down] = 0.0
        self._pos[rows], self._vel[rows] = pos, vel
        self._airspeed[rows] = np.linalg.norm(vel, axis=1)

    def _drain(self, rows: NDArray[np.intp], dt: float) -> None:
        rest = self._rest[rows]
        power = rest + (1.0 - rest) * self._airspeed[rows] / self._max_speed[rows]
        battery = self._battery[rows] - power * self._drain_scale[rows] * dt
        empty = battery <= 0.0
        self._battery[rows] = np.maximum(battery, 0.0)
        if empty.any():
            dead = rows[empty]
            self._mode[dead] = DEAD
            self._pending[dead] = False
            # One that dies on the ground (rolling) stops there; one in the air falls.
            grounded = dead[self._pos[dead, 2] <= 0.0]
            self._vel[grounded] = 0.0
            self._airspeed[grounded] = 0.0

    # --- commands (through SimVehicle) -----------------------------------------------------------

    def drain_faster(self, platform: int, factor: float) -> None:
        """Make ``platform``'s battery drain ``factor`` times faster from now on (a worn or
        cold battery: ``actorswarm sim --drain``). ValueError for a factor under 1."""
        if not (_is_number(factor) and factor >= 1.0):
            raise ValueError(f"drain factor must be a number >= 1, not {factor!r}")
        self._drain_scale[self.index(platform)] *= factor

    def _goto(self, row: int, x: float, y: float, z: float, speed: float | None) -> None:
        goal = _finite_point("goto", (x, y, z))
        if speed is not None and not (_is_number(speed) and speed > 0):
            raise ValueError(f"goto: speed must be a positive number (m/s) or None, not {speed!r}")
        mode = int(self._mode[row])
        if mode == DEAD:
            return
        chosen = self._cruise[row] if speed is None else float(speed)
        self._speed_cmd[row] = min(max(chosen, self._min_speed[row]), self._max_speed[row])
        # The ground has no terrain below it.
        goal = (goal[0], goal[1], max(goal[2], 0.0))
        self._goal[row] = goal
        if self._on_wheels(row):
            # Take off towards the goal's altitude, then fly on; a goal on the ground leaves
            # a landed vehicle where it is (there is no taxiing).
            if goal[2] > _ARRIVE:
                self._start_takeoff(row, goal[2])
                self._pending[row] = True
        elif mode == TAKEOFF:
            self._pending[row] = True
        else:
            self._mode[row] = FLYING
            self._aim[row] = goal

    def _takeoff(self, row: int, altitude: float) -> None:
        if not (_is_number(altitude) and altitude > 0):
            raise ValueError(
                f"takeoff: altitude must be a positive number (metres), not {altitude!r}"
            )
        mode = int(self._mode[row])
        if mode == DEAD:
            return
        if self._on_wheels(row):
            self._start_takeoff(row, float(altitude))
            distance = self._takeoff_dist[row]
            # A fixed-wing with a take-off distance climbs out towards the point that far
            # down its runway and circles it (ArduPlane's TKOFF_DIST), as towards a goal.
            self._pending[row] = distance > 0.0
            if distance > 0.0:
                heading = self._heading[row]
                self._goal[row] = (
                    self._pos[row, 0] + distance * math.cos(heading),
                    self._pos[row, 1] + distance * math.sin(heading),
                    altitude,
                )
        elif mode == TAKEOFF:
            self._takeoff_alt[row] = altitude
            self._aim[row, 2] = altitude
            self._pending[row] = False
        else:
            # Already airborne: climb (or descend) to the altitude where it is, and stay.
            x, y = self._pos[row, 0], self._pos[row, 1]
            self._mode[row] = FLYING
            self._aim[row] = self._goal[row] = (x, y, altitude)
            self._speed_cmd[row] = self._cruise[row]

    def _on_wheels(self, row: int) -> bool:
        """On the ground: never flown, landed, or a fixed-wing rolling out after touchdown
        (below its stall speed, so it must take off again rather than just fly on)."""
        mode = int(self._mode[row])
        rolling = mode == LANDING and self._is_fw[row] and self._pos[row, 2] <= 0.0
        return mode in (GROUND, LANDED) or bool(rolling)

    def _start_takeoff(self, row: int, altitude: float) -> None:
        self._mode[row] = TAKEOFF
        self._takeoff_alt[row] = altitude
        self._aim[row] = (self._pos[row, 0], self._pos[row, 1], altitude)

    def _hold(self, row: int) -> None:
        mode = int(self._mode[row])
        if mode == TAKEOFF:
            # Finish the climb and stay there: forget any goto given meanwhile.
            self._pending[row] = False
        elif mode in (FLYING, LANDING) and not self._on_wheels(row):
            self._mode[row] = FLYING
            self._speed_cmd[row] = self._cruise[row]
            here = self._pos[row].copy()
            if not self._is_fw[row]:
                # Hold where a brake at the planned deceleration comes to rest, not where the
                # command found it: turning back to that point would overshoot it.
                vel = self._vel[row]
                here += vel * (np.linalg.norm(vel) / (2.0 * _BRAKE * self._accel[row]))
                here[2] = max(here[2], 0.0)
            self._aim[row] = self._goal[row] = here

    def _land(self, row: int) -> None:
        mode = int(self._mode[row])
        if mode in (TAKEOFF, FLYING):
            self._mode[row] = LANDING
            self._pending[row] = False
            self._aim[row] = (self._pos[row, 0], self._pos[row, 1], 0.0)
            self._glide_tan[row] = 0.0

    def _land_at(
        self, row: int, point: tuple[float, float], start: tuple[float, float, float]
    ) -> None:
        x, y, _ = _finite_point("land_at", (point[0], point[1], 0.0))
        sx, sy, sz = _finite_point("land_at", start)
        if not (self._is_fw[row] and self._glide[row] > 0.0):
            raise ValueError("land_at: only a fixed-wing with a glide_slope lands at a point")
        if int(self._mode[row]) not in (TAKEOFF, FLYING) or self._on_wheels(row):
            return
        top = max(sz, 0.0)
        span = math.hypot(sx - x, sy - y)
        # The line falls at glide_slope, or more steeply when that would land past the point.
        tan = max(float(self._glide[row]), top / span if span > 0.0 else math.inf)
        self._mode[row] = LANDING
        self._pending[row] = False
        self._aim[row] = (x, y, 0.0)
        self._glide_tan[row] = min(tan, 1.0)
        self._glide_short[row] = max(span - top / self._glide_tan[row], 0.0)
        self._glide_top[row] = top

    def _set_loiter_radius(self, row: int, radius: float) -> None:
        if not (_is_number(radius) and radius > 0):
            raise ValueError(f"loiter radius must be a positive number (metres), not {radius!r}")
        if self._is_fw[row]:
            self._loiter[row] = radius


class SimVehicle:
    """One simulated vehicle: a :class:`~actorswarm.runtime.context.Vehicle` backed by a
    row of a :class:`Fleet`.

    Commands set goals and return at once; the fleet acts on them from its next step.
    Arguments are checked (a NaN, a non-positive speed or altitude raises ValueError);
    speeds are clamped to what the kind can fly (a fixed-wing's [min_airspeed, max_speed],
    a quadrotor's max_speed). A dead vehicle ignores every command. Per kind and mode:

    ``goto``
        Airborne: fly there (a fixed-wing circles it at its loiter radius). During a
        take-off: go there once at altitude. On the ground: take off to the goal's altitude,
        then go there (a goal on the ground leaves it where it is). A fixed-wing rolling
        out after touchdown is on the ground: it takes off again along its heading.
    ``hold``
        A quadrotor brakes and hovers where it comes to rest; a fixed-wing circles its
        current position. During a take-off: stay at the take-off altitude. Aborts a
        landing. Nothing on the ground.
    ``land``
        A quadrotor descends onto the point below it; a fixed-wing descends straight ahead,
        touches down and brakes. Nothing on the ground.
    ``takeoff``
        On the ground: take off to ``altitude`` above it (a fixed-wing along its runway
        heading). Airborne: climb or descend to ``altitude`` where it is and stay there.
    """

    __slots__ = ("_fleet", "_row", "kind", "platform")

    def __init__(self, fleet: Fleet, row: int) -> None:
        self._fleet = fleet
        self._row = row
        self.platform: int = fleet.platforms[row]
        self.kind: Kind = fleet.kinds[row]

    def home(self) -> tuple[float, float, float]:
        """Where this vehicle started (its home position on the ground)."""
        x, y, z = self._fleet._home[self._row].tolist()
        return (x, y, z)

    def __repr__(self) -> str:
        x, y, z = self.position()
        return (
            f"SimVehicle(platform={self.platform}, kind={self.kind!r}, mode={self.mode!r}, "
            f"position=({x:.1f}, {y:.1f}, {z:.1f}), battery={self.battery():.3f})"
        )

    # --- the Vehicle interface -------------------------------------------------------------------

    def position(self) -> tuple[float, float, float]:
        p = self._fleet._pos[self._row]
        return (float(p[0]), float(p[1]), float(p[2]))

    def velocity(self) -> tuple[float, float, float]:
        v = self._fleet._vel[self._row]
        return (float(v[0]), float(v[1]), float(v[2]))

    def battery(self) -> float:
        return float(self._fleet._battery[self._row])

    def goto(self, x: float, y: float, z: float, *, speed: float | None = None) -> None:
        self._fleet._goto(self._row, x, y, z, speed)

    def hold(self) -> None:
        self._fleet._hold(self._row)

    def land(self) -> None:
        self._fleet._land(self._row)

    def takeoff(self, altitude: float) -> None:
        self._fleet._takeoff(self._row, altitude)

    # --- beyond the interface: a fixed-wing's refinements ----------------------------------------

    def land_at(self, x: float, y: float, *, start: tuple[float, float, float]) -> None:
        """Land a fixed-wing with a ``glide_slope`` on the point ``(x, y)``: steer straight at
        it and descend along the line from ``start`` (the approach point, ``(x, y, z)``) that
        falls at ``glide_slope`` — more steeply when that would touch down past the point —
        not above ``start``'s altitude, touching down where the line meets the ground, short
        of the point when the slope is steeper than ``start`` needs; then brake to a stop
        straight ahead. Nothing on the ground; ValueError for any other vehicle."""
        self._fleet._land_at(self._row, (x, y), start)

    def set_loiter_radius(self, radius: float) -> None:
        """Circle goals at ``radius`` metres from now on (a fixed-wing; others ignore it).
        A radius below the turn radius at the speed flown is flown wider, as it must be."""
        self._fleet._set_loiter_radius(self._row, radius)

    # --- beyond the interface --------------------------------------------------------------------

    @property
    def mode(self) -> Mode:
        """The vehicle's mode (:data:`MODES`)."""
        return MODES[int(self._fleet._mode[self._row])]

    def heading(self) -> float:
        """Heading, radians counter-clockwise from east."""
        return float(self._fleet._heading[self._row])

    def speed(self) -> float:
        """The magnitude of the velocity, m/s."""
        return float(self._fleet._airspeed[self._row])

    def goal(self) -> tuple[float, float, float]:
        """The point the vehicle steers to now (the take-off point above home while taking
        off, the circle's centre for a loitering fixed-wing)."""
        a = self._fleet._aim[self._row]
        return (float(a[0]), float(a[1]), float(a[2]))

    @property
    def airborne(self) -> bool:
        """In the air, or rolling for take-off or after landing."""
        return int(self._fleet._mode[self._row]) in (TAKEOFF, FLYING, LANDING)


def _braking_speed(distance: FloatArray, decel: FloatArray, dt: float) -> FloatArray:
    """The highest speed from which braking by ``decel · dt`` per step, moving
    ``speed · dt`` per step after each change (as :meth:`Fleet.step` integrates), stops
    within ``distance``: the root of ``v² / (2 decel) + v dt / 2 = distance``. (The
    continuous ``sqrt(2 decel d)`` would overshoot by the half step.)"""
    half = 0.5 * decel * dt
    out: FloatArray = np.sqrt(half * half + 2.0 * decel * distance) - half
    return out


def _wrap(angle: FloatArray) -> FloatArray:
    """Angles folded into (-π, π]."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


def _readonly(array: _A) -> _A:
    view = array.view()
    view.flags.writeable = False
    return view


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _finite_point(what: str, value: tuple[float, float, float]) -> tuple[float, float, float]:
    if not all(_is_number(v) for v in value):
        raise ValueError(f"{what}: a point is three finite numbers (x, y, z), not {value!r}")
    return (float(value[0]), float(value[1]), float(value[2]))


def _span(ids: Sequence[int]) -> str:
    if not ids:
        return "none"
    if list(ids) == list(range(ids[0], ids[0] + len(ids))):
        return f"{ids[0]}-{ids[-1]}" if len(ids) > 1 else str(ids[0])
    return ", ".join(map(str, ids))
