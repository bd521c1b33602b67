"""The world description: vehicles, home positions, targets, areas and radio, from TOML.

Theory of operation
-------------------
A task script says *what* the swarm does; the world file says *where* and *with what*, so
one script runs unchanged on quadrotors or fixed-wings, in a field or over a valley
(docs/design.md §6). :func:`load_world` reads the file with :mod:`tomllib` and builds a frozen
:class:`WorldConfig`; every key has a default, so an empty file (or no file at all:
``load_world(None)``) is a valid world of quadrotors on a grid.

The file's top-level tables:

``[world]``
    Settings independent of any seed: the physics ``step`` (seconds).
``[fleet]``
    The default vehicle ``kind``, an optional list of ``platforms``, the home grid
    (``origin``, ``spacing``, ``columns``), the home ``heading`` (runway direction) and
    starting ``battery``; ``[[fleet.groups]]`` give a kind (and heading, battery) to ranges
    of platform IDs (``platforms = "1-10, 15"``).
``[[vehicles]]``
    One platform each: an explicit ``home``, ``kind``, ``heading`` or ``battery``, over
    what its group and the fleet say.
``[quadrotor]``, ``[fixed_wing]``
    The performance of each kind (:class:`QuadrotorParams`, :class:`FixedWingParams`).
``[[targets]]``
    Moving targets (the paper's jeep): a ``route`` of waypoints driven at ``speed``, once or
    in a ``loop`` (:class:`TargetConfig`).
``[[areas]]``
    Named regions, a ``rect`` or a ``polygon`` (:class:`Area`), e.g. the search area.
``[radio]``
    How distance degrades the radio (:class:`RadioConfig`, used by
    :mod:`actorswarm.world.radio_model`).
``[camera]``
    Every vehicle's downward-looking camera: field of view, range, the least altitude it
    works at (:class:`CameraConfig`, used by :mod:`actorswarm.world.sensors`).
``[safety]``
    The altitude ``ceiling`` and whether a separation breach stops a run
    (:class:`SafetyConfig`); each kind's least ``separation`` is in its own table.

Units are SI — metres, seconds, m/s, m/s² — except angles, which are degrees in the file
(headings, turn rates) because that is how people write them; the physics converts. The
frame is ENU: x east, y north, z up, from the mission origin; a heading is measured
counter-clockwise from east (90 = north), as for a robot's yaw in that frame.

Validation happens at load, never later: a wrong key, type or value raises
:class:`WorldError` naming the file, the key path (``fleet.groups[1].platforms``; array
indices count from 0) and the problem, and an unknown key gets a did-you-mean, because a
misspelt key would otherwise silently fall back to its default. The dataclasses check their
own values in ``__post_init__``, so a config built in code is held to the same rules; the
loader only adds the file and the key path to their messages.

Which platforms exist is not the world file's decision but the run's: :meth:`WorldConfig.
vehicle_specs` resolves the kind, home, heading and battery of any list of platform IDs
(precedence: ``[[vehicles]]`` entry, then the group containing the ID, then ``[fleet]``).
The grid places the platforms in ascending ID order, row by row along x, ``columns`` per
row, so homes do not depend on the order IDs are given in.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final, Literal, TypeVar, cast, get_args

from actorswarm.core.wire import MAX_PLATFORM
from actorswarm.suggest import did_you_mean

__all__ = [
    "KINDS",
    "Area",
    "CameraConfig",
    "FixedWingParams",
    "FleetConfig",
    "FleetGroup",
    "Kind",
    "QuadrotorParams",
    "RadioConfig",
    "SafetyConfig",
    "TargetConfig",
    "VehicleEntry",
    "VehicleSpec",
    "WorldConfig",
    "WorldError",
    "WorldSettings",
    "load_world",
    "loads_world",
    "parse_platforms",
]

Kind = Literal["quadrotor", "fixed_wing"]
#: The vehicle kinds, as written in a world file.
KINDS: Final[tuple[Kind, ...]] = get_args(Kind)

Point2 = tuple[float, float]
Point3 = tuple[float, float, float]

_T = TypeVar("_T")


class WorldError(ValueError):
    """A world description is wrong. The message names the file (or the class, for a config
    built in code), the key path and the problem; the three parts are also attributes."""

    def __init__(self, source: str, key: str, problem: str) -> None:
        super().__init__(f"{source}: {key}: {problem}" if key else f"{source}: {problem}")
        self.source = source
        self.key = key
        self.problem = problem


# --- value checks shared by the dataclasses ------------------------------------------------------


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _fail(owner: object, key: str, problem: str) -> WorldError:
    return WorldError(type(owner).__name__, key, problem)


def _positive(owner: object, *names: str) -> None:
    for name in names:
        value = getattr(owner, name)
        if not (_is_number(value) and value > 0):
            raise _fail(owner, name, f"must be a finite number > 0, not {value!r}")


def _non_negative(owner: object, *names: str) -> None:
    for name in names:
        value = getattr(owner, name)
        if not (_is_number(value) and value >= 0):
            raise _fail(owner, name, f"must be a finite number >= 0, not {value!r}")


def _fraction(owner: object, name: str, *, open_low: bool = False) -> None:
    value = getattr(owner, name)
    low_ok = _is_number(value) and (value > 0 if open_low else value >= 0)
    if not (low_ok and value <= 1):
        interval = "(0, 1]" if open_low else "[0, 1]"
        raise _fail(owner, name, f"must be a number in {interval}, not {value!r}")


def _point(owner: object, name: str, value: object, size: int) -> None:
    if not (isinstance(value, tuple) and len(value) == size and all(_is_number(v) for v in value)):
        raise _fail(owner, name, f"must be {size} finite numbers, not {value!r}")


def _kind(owner: object, name: str, value: object) -> None:
    if value not in KINDS:
        hint = did_you_mean(str(value), KINDS)
        raise _fail(owner, name, f"unknown vehicle kind {value!r}{hint}; kinds: {_list(KINDS)}")


def _list(items: Iterable[str]) -> str:
    return ", ".join(f'"{item}"' for item in items)


# --- the sections --------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class WorldSettings:
    """``[world]``: settings of the simulation itself.

    ``step``: the fixed physics step, seconds. Smaller is more faithful and slower; 0.05 s
    keeps a 25 m/s fixed-wing within 1.25 m per step, well under every distance the
    missions care about.
    """

    step: float = 0.05

    def __post_init__(self) -> None:
        _positive(self, "step")
        if self.step > 1.0:
            raise _fail(self, "step", f"must be at most 1 second, not {self.step!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class QuadrotorParams:
    """``[quadrotor]``: the performance of a multirotor.

    ``max_speed`` bounds the speed (the 3-D velocity's magnitude), ``cruise_speed`` is the
    speed of a ``goto`` that names none, ``max_accel`` bounds every change of velocity (any
    direction) and ``max_climb`` the vertical speed, up and down (take-off and landing
    included). A quadrotor can stop and hover anywhere.

    Battery: ``endurance`` is the flight time, seconds, of a full battery at cruise speed.
    The draw grows linearly with speed, from ``rest_power`` (the share of full-speed power
    a hover takes) at rest to 1 at ``max_speed``; a hovering quadrotor therefore lasts a
    little longer than ``endurance``, one racing at full speed a little less.

    ``separation``: the least distance, metres, a quadrotor in the air must keep from any
    other airborne vehicle (a pair keeps the larger of its two kinds'):
    :mod:`actorswarm.world.separation` measures it in every run.
    """

    max_speed: float = 12.0
    cruise_speed: float = 8.0
    max_accel: float = 4.0
    max_climb: float = 3.0
    endurance: float = 1200.0
    rest_power: float = 0.7
    separation: float = 3.0

    def __post_init__(self) -> None:
        _positive(
            self, "max_speed", "cruise_speed", "max_accel", "max_climb", "endurance", "separation"
        )
        _fraction(self, "rest_power", open_low=True)
        if self.cruise_speed > self.max_speed:
            raise _fail(
                self,
                "cruise_speed",
                f"{self.cruise_speed!r} m/s is above max_speed ({self.max_speed!r} m/s)",
            )


@dataclass(frozen=True, slots=True, kw_only=True)
class FixedWingParams:
    """``[fixed_wing]``: the performance of a fixed-wing aircraft. The defaults are
    ArduPlane 4.5.7's as flown in SITL with its stock airframe (``plane.parm``), so that a
    world that says nothing flies the aircraft the project's fixed-wing vehicle flies for
    real; ``tests/world/test_fixedwing_conformance.py`` pins the model to those figures.

    Once airborne its speed stays within [``min_airspeed``, ``max_speed``] (below it would
    stall); ``cruise_speed`` is the speed of a ``goto`` that names none. ``max_turn_rate``
    (degrees per second) bounds heading changes, ``max_climb`` the vertical speed, and
    ``max_accel`` every change of airspeed and of vertical speed. It never stops in the
    air: at its goal, or told to hold, it circles the point at ``loiter_radius`` metres,
    clockwise unless ``loiter_clockwise`` is false.

    ``loiter_radius`` must be at least the turn radius at ``cruise_speed``
    (``cruise_speed / max_turn_rate``; 48.5 m for the defaults, which is why ArduPlane's
    tightest sustained circle is about 50 m): faster than that, the circle is flown wider,
    as a real aircraft does at its bank limit. ``max_climb`` must be below
    ``min_airspeed``, because the climb is part of the airspeed.

    Take-off and landing: the take-off roll accelerates at ``max_accel`` and lifts off at
    ``rotate_speed`` (0: ``min_airspeed``); from ``level_altitude`` metres up (0: never) the
    climbing aircraft turns towards its goal while it climbs on (ArduPlane's
    ``TKOFF_LVL_ALT``), the point ``takeoff_distance`` metres ahead of where it started
    (ArduPlane's ``TKOFF_DIST``) unless a goal was given (0: none; it then climbs straight
    ahead and circles where it reached its altitude); ``climb_gain`` (1/s, 0: off) also
    bounds the vertical speed by that many times the height still to climb or descend, the
    slowing approach of an energy controller. ``glide_slope`` (degrees, 0: none) and
    ``landing_speed`` (m/s, 0: ``min_airspeed``) shape a landing to a point
    (:meth:`~actorswarm.world.vehicles.SimVehicle.land_at`, which needs a glide slope).

    Battery: as for :class:`QuadrotorParams` — ``endurance`` seconds at cruise speed, the
    draw growing linearly from ``rest_power`` (extrapolated to zero airspeed) to 1 at
    ``max_speed``.

    ``separation``: the least distance, metres, a fixed-wing in the air must keep from any
    other airborne vehicle (as for :class:`QuadrotorParams`).
    """

    # ArduPlane's AIRSPEED_MIN, AIRSPEED_MAX and AIRSPEED_CRUISE.
    min_airspeed: float = 10.0
    max_speed: float = 30.0
    cruise_speed: float = 22.0
    # 22 m/s on a 48.5 m circle: the tightest circle measured (~50 m at 56° of bank).
    max_turn_rate: float = 26.0
    # 80 to 120 m in 8.2 s of a take-off to 162 m (TECS_CLMB_MAX is 5).
    max_climb: float = 4.8
    # 0 to 19.5 m/s in 3.8 s on the runway.
    max_accel: float = 5.13
    # A goal asked for with the vehicle's radius (30 m) is circled at ~50 m.
    loiter_radius: float = 50.0
    endurance: float = 3600.0
    rest_power: float = 0.5
    separation: float = 10.0
    loiter_clockwise: bool = True
    # Wheels off at 19.5 m/s, 3.8 s and ~40 m down the runway.
    rotate_speed: float = 19.5
    level_altitude: float = 5.0
    # 20 m at +10.8 s and TKOFF_ALT - 1 at +30 s of a take-off to 40 m.
    climb_gain: float = 0.158
    # ArduPlane's TKOFF_DIST: a take-off with no goal circles the point this far ahead.
    takeoff_distance: float = 200.0
    # The measured landing: a 3.5° glide at 16 m/s.
    glide_slope: float = 3.5
    landing_speed: float = 16.0

    def __post_init__(self) -> None:
        _positive(
            self,
            "separation",
            "min_airspeed",
            "max_speed",
            "cruise_speed",
            "max_turn_rate",
            "max_climb",
            "max_accel",
            "loiter_radius",
            "endurance",
        )
        _non_negative(
            self,
            "rotate_speed",
            "level_altitude",
            "climb_gain",
            "takeoff_distance",
            "glide_slope",
            "landing_speed",
        )
        _fraction(self, "rest_power", open_low=True)
        if not isinstance(self.loiter_clockwise, bool):
            raise _fail(
                self, "loiter_clockwise", f"must be true or false, not {self.loiter_clockwise!r}"
            )
        if self.glide_slope >= 45.0:
            raise _fail(self, "glide_slope", f"must be below 45 degrees, not {self.glide_slope!r}")
        if self.min_airspeed > self.max_speed:
            raise _fail(
                self,
                "min_airspeed",
                f"{self.min_airspeed!r} m/s is above max_speed ({self.max_speed!r} m/s)",
            )
        if not self.min_airspeed <= self.cruise_speed <= self.max_speed:
            raise _fail(
                self,
                "cruise_speed",
                f"{self.cruise_speed!r} m/s is outside [min_airspeed, max_speed] "
                f"= [{self.min_airspeed!r}, {self.max_speed!r}] m/s",
            )
        if self.max_climb >= self.min_airspeed:
            raise _fail(
                self,
                "max_climb",
                f"{self.max_climb!r} m/s must be below min_airspeed ({self.min_airspeed!r} "
                "m/s): the climb is part of the airspeed",
            )
        if self.max_turn_rate > 360.0:
            raise _fail(
                self, "max_turn_rate", f"must be at most 360 °/s, not {self.max_turn_rate!r}"
            )
        smallest = self.turn_radius(self.cruise_speed)
        if self.loiter_radius < smallest:
            raise _fail(
                self,
                "loiter_radius",
                f"{self.loiter_radius!r} m is tighter than the turn radius at cruise_speed "
                f"({smallest:.1f} m = cruise_speed / max_turn_rate)",
            )

    @property
    def turn_rate_rad(self) -> float:
        """``max_turn_rate`` in radians per second."""
        return math.radians(self.max_turn_rate)

    def turn_radius(self, speed: float) -> float:
        """The tightest circle, metres, flown at ``speed`` m/s."""
        return speed / self.turn_rate_rad


VehicleParams = QuadrotorParams | FixedWingParams


@dataclass(frozen=True, slots=True, kw_only=True)
class SafetyConfig:
    """``[safety]``: the limits every run is held to.

    ``ceiling``: the highest altitude, metres above the ground, any vehicle may be sent to
    (0: none); ``actorswarm task check --world`` warns at a script line that asks for more.
    ``fatal_separation``: a separation breach (two airborne vehicles closer than their
    kinds' ``separation``) stops the run at once instead of being reported at its end.
    """

    ceiling: float = 0.0
    fatal_separation: bool = False

    def __post_init__(self) -> None:
        _non_negative(self, "ceiling")
        if not isinstance(self.fatal_separation, bool):
            raise _fail(
                self, "fatal_separation", f"must be true or false, not {self.fatal_separation!r}"
            )


@dataclass(frozen=True, slots=True, kw_only=True)
class FleetGroup:
    """``[[fleet.groups]]``: a kind (and optionally heading and battery) for some platforms."""

    platforms: tuple[int, ...]
    kind: Kind
    heading: float | None = None
    battery: float | None = None

    def __post_init__(self) -> None:
        _check_ids(self, "platforms", self.platforms)
        if not self.platforms:
            raise _fail(self, "platforms", "names no platform")
        _kind(self, "kind", self.kind)
        _optional_heading_battery(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleEntry:
    """``[[vehicles]]``: what one platform has of its own; None leaves it to the fleet."""

    platform: int
    kind: Kind | None = None
    home: Point2 | None = None
    heading: float | None = None
    battery: float | None = None

    def __post_init__(self) -> None:
        _check_ids(self, "platform", (self.platform,))
        if self.kind is not None:
            _kind(self, "kind", self.kind)
        if self.home is not None:
            _point(self, "home", self.home, 2)
        _optional_heading_battery(self)


def _optional_heading_battery(owner: FleetGroup | VehicleEntry) -> None:
    if owner.heading is not None and not _is_number(owner.heading):
        raise _fail(owner, "heading", f"must be a finite number of degrees, not {owner.heading!r}")
    if owner.battery is not None:
        _fraction(owner, "battery", open_low=True)


def _check_ids(owner: object, name: str, ids: Sequence[int]) -> None:
    for pid in ids:
        if isinstance(pid, bool) or not isinstance(pid, int) or not 1 <= pid <= MAX_PLATFORM:
            raise _fail(owner, name, f"platform IDs are integers 1..{MAX_PLATFORM}, not {pid!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class FleetConfig:
    """``[fleet]``: the vehicles every platform gets unless a group or entry says otherwise.

    ``kind``: the default kind. ``platforms``: the platform IDs of the world when the run
    does not name them (None: the run must). Homes lie on a grid from ``origin`` (x, y),
    ``spacing`` metres apart, ``columns`` per row (0: the smallest square that fits).
    ``heading`` (degrees, counter-clockwise from east) is the direction each vehicle faces at
    home — the runway direction a fixed-wing takes off along. ``battery`` is the starting
    charge, in (0, 1].
    """

    kind: Kind = "quadrotor"
    platforms: tuple[int, ...] | None = None
    origin: Point2 = (0.0, 0.0)
    spacing: float = 10.0
    columns: int = 0
    heading: float = 90.0
    battery: float = 1.0
    groups: tuple[FleetGroup, ...] = ()

    def __post_init__(self) -> None:
        _kind(self, "kind", self.kind)
        if self.platforms is not None:
            _check_ids(self, "platforms", self.platforms)
            if len(set(self.platforms)) != len(self.platforms):
                raise _fail(self, "platforms", "names a platform twice")
        _point(self, "origin", self.origin, 2)
        _positive(self, "spacing")
        if isinstance(self.columns, bool) or not isinstance(self.columns, int) or self.columns < 0:
            raise _fail(self, "columns", f"must be an integer >= 0, not {self.columns!r}")
        if not _is_number(self.heading):
            raise _fail(
                self, "heading", f"must be a finite number of degrees, not {self.heading!r}"
            )
        _fraction(self, "battery", open_low=True)
        owner: dict[int, int] = {}
        for index, group in enumerate(self.groups):
            for pid in group.platforms:
                if pid in owner:
                    raise _fail(
                        self,
                        f"groups[{index}].platforms",
                        f"platform {pid} is already in groups[{owner[pid]}]",
                    )
                owner[pid] = index


@dataclass(frozen=True, slots=True, kw_only=True)
class TargetConfig:
    """``[[targets]]``: a target that moves on its own, like the paper's jeep.

    It starts at the first waypoint of ``route`` (points ``(x, y)`` or ``(x, y, z)``; z
    defaults to 0, the ground), waits there until ``start`` seconds, then drives from
    waypoint to waypoint at ``speed`` m/s. With ``loop`` it drives back to the first
    waypoint and round again forever; without, it stops at the last one. ``kind`` is a free
    label (``"jeep"``) for detection plugins and pictures.
    """

    name: str
    route: tuple[Point3, ...]
    speed: float
    kind: str = "jeep"
    loop: bool = True
    start: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise _fail(self, "name", f"must be a non-empty string, not {self.name!r}")
        if not isinstance(self.kind, str) or not self.kind:
            raise _fail(self, "kind", f"must be a non-empty string, not {self.kind!r}")
        if not self.route:
            raise _fail(self, "route", "needs at least one waypoint")
        for index, point in enumerate(self.route):
            _point(self, f"route[{index}]", point, 3)
        _non_negative(self, "speed", "start")
        if not isinstance(self.loop, bool):
            raise _fail(self, "loop", f"must be true or false, not {self.loop!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class Area:
    """``[[areas]]``: a named region of the ground, a simple polygon of ``(x, y)`` vertices
    (a ``rect = [x_min, y_min, x_max, y_max]`` in the file becomes its four corners)."""

    name: str
    polygon: tuple[Point2, ...]

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise _fail(self, "name", f"must be a non-empty string, not {self.name!r}")
        if len(self.polygon) < 3:
            raise _fail(self, "polygon", f"needs at least 3 vertices, has {len(self.polygon)}")
        for index, point in enumerate(self.polygon):
            _point(self, f"polygon[{index}]", point, 2)
        if self.area <= 0.0:
            raise _fail(self, "polygon", "encloses no area (its vertices are on one line)")

    @classmethod
    def rect(cls, name: str, x_min: float, y_min: float, x_max: float, y_max: float) -> Area:
        """The rectangle ``[x_min, x_max] × [y_min, y_max]``, corners counter-clockwise."""
        if not (x_min < x_max and y_min < y_max):
            raise WorldError(
                cls.__name__, "rect", "must be [x_min, y_min, x_max, y_max] with min < max"
            )
        corners = ((x_min, y_min), (x_max, y_min), (x_max, y_max), (x_min, y_max))
        return cls(name=name, polygon=tuple((float(x), float(y)) for x, y in corners))

    @property
    def area(self) -> float:
        """The enclosed area, m² (shoelace formula)."""
        return abs(_signed_area(self.polygon))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)``."""
        xs = [p[0] for p in self.polygon]
        ys = [p[1] for p in self.polygon]
        return (min(xs), min(ys), max(xs), max(ys))

    @property
    def centroid(self) -> Point2:
        """The centre of mass of the enclosed region."""
        a = _signed_area(self.polygon)
        cx = cy = 0.0
        for (x0, y0), (x1, y1) in _edges(self.polygon):
            cross = x0 * y1 - x1 * y0
            cx += (x0 + x1) * cross
            cy += (y0 + y1) * cross
        return (cx / (6.0 * a), cy / (6.0 * a))

    def contains(self, x: float, y: float) -> bool:
        """Whether ``(x, y)`` lies inside (even-odd rule; points on an edge may go either
        way)."""
        inside = False
        for (x0, y0), (x1, y1) in _edges(self.polygon):
            if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
                inside = not inside
        return inside


def _edges(polygon: Sequence[Point2]) -> Iterable[tuple[Point2, Point2]]:
    return zip(polygon, (*polygon[1:], polygon[0]), strict=True)


def _signed_area(polygon: Sequence[Point2]) -> float:
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in _edges(polygon))


@dataclass(frozen=True, slots=True, kw_only=True)
class RadioConfig:
    """``[radio]``: how distance degrades a radio link (the model is in
    :mod:`actorswarm.world.radio_model`).

    ``range``: metres beyond which nothing gets through. Within it the loss probability is
    ``loss_at_range * (d / range) ** loss_exponent`` — near zero close by, steep towards the
    edge with a large exponent. Latency is ``base_latency + latency_per_km * d / 1000``
    seconds; the radio adds a jitter drawn in ``[0, jitter]`` seconds from its seeded
    generator. ``relay``: the platforms forward for each other (the daemons' ``--relay``),
    so a packet reaches a platform out of range through others, each relay adding
    ``relay_latency`` seconds; off, a platform hears only those within ``range``.
    """

    range: float = 2000.0
    loss_at_range: float = 0.2
    loss_exponent: float = 4.0
    base_latency: float = 0.005
    latency_per_km: float = 0.001
    jitter: float = 0.002
    relay: bool = False
    relay_latency: float = 0.002

    def __post_init__(self) -> None:
        _positive(self, "range", "loss_exponent")
        _fraction(self, "loss_at_range")
        _non_negative(self, "base_latency", "latency_per_km", "jitter", "relay_latency")


@dataclass(frozen=True, slots=True, kw_only=True)
class CameraConfig:
    """``[camera]``: every vehicle's downward-looking camera (the simulated
    :class:`~actorswarm.runtime.context.Camera`, in :mod:`actorswarm.world.sensors`).

    A target is seen when the vehicle is at least ``min_altitude`` metres up, the target is
    within ``field_of_view / 2`` degrees of straight down, and no further than
    ``max_range`` metres (slant range). At altitude ``h`` the footprint on the ground is a
    disc of radius ``h · tan(field_of_view / 2)``.
    """

    field_of_view: float = 90.0
    max_range: float = 200.0
    min_altitude: float = 2.0

    def __post_init__(self) -> None:
        _positive(self, "field_of_view", "max_range")
        _non_negative(self, "min_altitude")
        if self.field_of_view >= 180.0:
            raise _fail(
                self, "field_of_view", f"must be below 180 degrees, not {self.field_of_view:g}"
            )


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleSpec:
    """One platform's vehicle, resolved from the world: kind, home ``(x, y)`` on the ground,
    ``heading`` in radians (counter-clockwise from east), starting ``battery`` and the
    kind's performance ``params``."""

    platform: int
    kind: Kind
    home: Point2
    heading: float
    battery: float
    params: VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class WorldConfig:
    """A whole world (see the module docstring for the file layout).

    ``source`` names where it came from, for messages (a path, or ``<defaults>``).
    """

    world: WorldSettings = field(default_factory=WorldSettings)
    fleet: FleetConfig = field(default_factory=FleetConfig)
    vehicles: tuple[VehicleEntry, ...] = ()
    quadrotor: QuadrotorParams = field(default_factory=QuadrotorParams)
    fixed_wing: FixedWingParams = field(default_factory=FixedWingParams)
    targets: tuple[TargetConfig, ...] = ()
    areas: tuple[Area, ...] = ()
    radio: RadioConfig = field(default_factory=RadioConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    safety: SafetyConfig = field(default_factory=SafetyConfig)
    source: str = "<defaults>"

    def __post_init__(self) -> None:
        seen: dict[int, int] = {}
        for index, entry in enumerate(self.vehicles):
            if entry.platform in seen:
                raise _fail(
                    self,
                    f"vehicles[{index}].platform",
                    f"platform {entry.platform} already has an entry: "
                    f"vehicles[{seen[entry.platform]}]",
                )
            seen[entry.platform] = index
        sections = (
            ("targets", [target.name for target in self.targets]),
            ("areas", [area.name for area in self.areas]),
        )
        for section, names in sections:
            first: dict[str, int] = {}
            for index, name in enumerate(names):
                if name in first:
                    raise _fail(
                        self,
                        f"{section}[{index}].name",
                        f"{name!r} is already the name of {section}[{first[name]}]",
                    )
                first[name] = index

    @classmethod
    def defaults(cls, platforms: Iterable[int], kind: Kind = "quadrotor") -> WorldConfig:
        """The default world for ``platforms``, every vehicle of ``kind``."""
        try:
            fleet = FleetConfig(kind=kind, platforms=tuple(platforms))
        except WorldError as exc:
            raise WorldError("WorldConfig.defaults", exc.key, exc.problem) from None
        return cls(fleet=fleet)

    def fleet_of(self, platform: int, fleet: Iterable[int] | None = None) -> tuple[int, ...]:
        """The swarm ``platform`` flies in, for its home on the fleet's grid: ``fleet`` when
        given, else the world's ``fleet.platforms``, else ``platform`` alone (the first
        home). WorldError when the swarm named does not hold ``platform``."""
        ids = tuple(sorted(set(fleet))) if fleet is not None else self.fleet.platforms
        if ids is None:
            return (platform,)
        if platform not in ids:
            key = "fleet" if fleet is not None else "fleet.platforms"
            raise WorldError(
                self.source, key, f"platform {platform} is not one of the swarm's platforms"
            )
        return ids

    def alone(self, platform: int, fleet: Iterable[int] | None = None) -> WorldConfig:
        """This world for ``platform``'s vehicle flown on its own (a daemon's ``--vehicle
        sim``), starting where the simulator would put it in a run of the platforms
        :meth:`fleet_of` gives: its home is pinned in a ``[[vehicles]]`` entry, so the
        one-vehicle world places it at its slot of the whole fleet's grid, not at the
        first slot."""
        spec = {s.platform: s for s in self.vehicle_specs(self.fleet_of(platform, fleet))}
        home = spec[platform].home
        others = tuple(e for e in self.vehicles if e.platform != platform)
        mine = next((e for e in self.vehicles if e.platform == platform), None)
        pinned = (
            VehicleEntry(platform=platform, home=home)
            if mine is None
            else dataclasses.replace(mine, home=home)
        )
        return dataclasses.replace(self, vehicles=(*others, pinned))

    def params(self, kind: Kind) -> VehicleParams:
        """The performance of ``kind``."""
        return self.quadrotor if kind == "quadrotor" else self.fixed_wing

    def separations(self) -> dict[str, float]:
        """The least separation of each kind, metres (``[<kind>] separation``)."""
        return {kind: self.params(kind).separation for kind in KINDS}

    def area(self, name: str) -> Area:
        """The area called ``name``; KeyError with a suggestion when there is none."""
        for area in self.areas:
            if area.name == name:
                return area
        known = [a.name for a in self.areas]
        raise KeyError(
            f"no area {name!r}{did_you_mean(name, known)} in {self.source}; "
            f"areas: {_list(known) or 'none'}"
        )

    def vehicle_specs(self, platforms: Iterable[int] | None = None) -> tuple[VehicleSpec, ...]:
        """The vehicle of each platform, in ascending platform order.

        ``platforms``: the run's platform IDs (None: ``fleet.platforms``). Entries and groups
        that name other platforms are ignored, so one world file serves swarms of any size.
        """
        if platforms is None:
            if self.fleet.platforms is None:
                raise WorldError(
                    self.source,
                    "fleet.platforms",
                    "the world names no platforms and the run gave none",
                )
            platforms = self.fleet.platforms
        ids = sorted(platforms)
        _check_ids(self, "platforms", ids)
        if len(set(ids)) != len(ids):
            raise WorldError(self.source, "platforms", "a platform is named twice")
        fleet = self.fleet
        columns = fleet.columns or max(1, math.ceil(math.sqrt(len(ids))))
        entries = {entry.platform: entry for entry in self.vehicles}
        groups = {pid: group for group in fleet.groups for pid in group.platforms}
        specs = []
        for slot, pid in enumerate(ids):
            entry = entries.get(pid)
            group = groups.get(pid)
            kind: Kind = _first(
                entry.kind if entry else None, group.kind if group else None, fleet.kind
            )
            home = _first(
                entry.home if entry else None,
                (
                    fleet.origin[0] + (slot % columns) * fleet.spacing,
                    fleet.origin[1] + (slot // columns) * fleet.spacing,
                ),
            )
            heading = _first(
                entry.heading if entry else None,
                group.heading if group else None,
                fleet.heading,
            )
            battery = _first(
                entry.battery if entry else None,
                group.battery if group else None,
                fleet.battery,
            )
            specs.append(
                VehicleSpec(
                    platform=pid,
                    kind=kind,
                    home=(float(home[0]), float(home[1])),
                    heading=math.radians(heading),
                    battery=float(battery),
                    params=self.params(kind),
                )
            )
        return tuple(specs)


def _first(*values: _T | None) -> _T:
    for value in values:
        if value is not None:
            return value
    raise AssertionError("no value and no default")  # pragma: no cover - the last is a default


# --- platform ID sets ----------------------------------------------------------------------------


def parse_platforms(value: object) -> tuple[int, ...]:
    """Platform IDs from a world file: an integer, a list of integers, or a string of IDs
    and inclusive ranges (``"1-10, 15, 20-22"``). Returns them sorted, without repeats;
    ValueError says what is wrong."""
    if isinstance(value, int) and not isinstance(value, bool):
        ids = [value]
    elif isinstance(value, list):
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
            raise ValueError(f"a list of platform IDs holds integers only, not {value!r}")
        ids = list(value)
    elif isinstance(value, str):
        ids = []
        for part in value.split(","):
            text = part.strip()
            low, dash, high = text.partition("-")
            try:
                first = int(low)
                last = int(high) if dash else first
            except ValueError:
                raise ValueError(
                    f'{text!r} is not a platform ID or range (write e.g. "1-10, 15")'
                ) from None
            if last < first:
                raise ValueError(f"the range {text!r} runs backwards")
            if first < 1 or last > MAX_PLATFORM:
                raise ValueError(f"{text!r}: platform IDs are 1..{MAX_PLATFORM}")
            ids.extend(range(first, last + 1))
    else:
        raise ValueError(
            f'platforms are an integer, a list of integers or a string like "1-10, 15", '
            f"not {value!r}"
        )
    for pid in ids:
        if not 1 <= pid <= MAX_PLATFORM:
            raise ValueError(f"platform IDs are 1..{MAX_PLATFORM}, not {pid}")
    return tuple(sorted(set(ids)))


# --- the loader ----------------------------------------------------------------------------------


def load_world(path: Path | None) -> WorldConfig:
    """The world described by the TOML file at ``path`` (None: the defaults).

    Raises :class:`WorldError` naming the file when it cannot be read, is not TOML, or
    describes an invalid world.
    """
    if path is None:
        return WorldConfig()
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise WorldError(source, "", f"cannot read the world file: {exc}") from None
    return loads_world(text, source=source)


def loads_world(text: str, *, source: str = "<string>") -> WorldConfig:
    """The world described by the TOML ``text``; ``source`` names it in messages."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise WorldError(source, "", f"not valid TOML: {exc}") from None
    return _Loader(source).world(data)


_TOP_KEYS: Final = (
    "world",
    "fleet",
    "vehicles",
    "quadrotor",
    "fixed_wing",
    "targets",
    "areas",
    "radio",
    "camera",
    "safety",
)


def _field_names(cls: type[Any], *, skip: Iterable[str] = ()) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls) if f.name not in set(skip))


class _Table:
    """One TOML table being read: typed getters that name the key path when they refuse."""

    def __init__(self, loader: _Loader, path: str, data: object, accepted: Sequence[str]) -> None:
        self.loader = loader
        self.path = path
        if not isinstance(data, dict):
            raise loader.error(path, f"must be a table, not {_describe(data)}")
        self.data: dict[str, Any] = data
        # Unknown keys first: a misspelt key would otherwise fall back to its default
        # without a word.
        for key in data:
            if key not in accepted:
                where = f"[{path}]" if path else "the top level"
                raise loader.error(
                    self.key(key),
                    f"unknown key{did_you_mean(key, accepted)}; the keys of {where} are "
                    f"{_list(accepted)}",
                )

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def has(self, name: str) -> bool:
        return name in self.data

    def number(self, name: str) -> float:
        value = self.data[name]
        if not _is_number(value):
            raise self.loader.error(self.key(name), f"must be a number, not {_describe(value)}")
        return float(value)

    def integer(self, name: str) -> int:
        value = self.data[name]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.loader.error(self.key(name), f"must be an integer, not {_describe(value)}")
        return value

    def boolean(self, name: str) -> bool:
        value = self.data[name]
        if not isinstance(value, bool):
            raise self.loader.error(
                self.key(name), f"must be true or false, not {_describe(value)}"
            )
        return value

    def string(self, name: str) -> str:
        value = self.data[name]
        if not isinstance(value, str):
            raise self.loader.error(self.key(name), f"must be a string, not {_describe(value)}")
        return value

    def point(self, name: str, sizes: tuple[int, ...], value: object = None) -> tuple[float, ...]:
        value = self.data[name] if value is None else value
        if not (
            isinstance(value, list) and len(value) in sizes and all(_is_number(v) for v in value)
        ):
            shape = " or ".join(str(n) for n in sizes) + " numbers"
            raise self.loader.error(self.key(name), f"must be {shape}, not {_describe(value)}")
        return tuple(float(v) for v in value)

    def points(self, name: str, sizes: tuple[int, ...]) -> list[tuple[float, ...]]:
        value = self.data[name]
        if not isinstance(value, list):
            raise self.loader.error(
                self.key(name), f"must be a list of points, not {_describe(value)}"
            )
        return [self.point(f"{name}[{i}]", sizes, item) for i, item in enumerate(value)]

    def platforms(self, name: str) -> tuple[int, ...]:
        try:
            return parse_platforms(self.data[name])
        except ValueError as exc:
            raise self.loader.error(self.key(name), str(exc)) from None

    def table(self, name: str, accepted: Sequence[str]) -> _Table:
        return _Table(self.loader, self.key(name), self.data.get(name, {}), accepted)

    def tables(self, name: str, accepted: Sequence[str]) -> list[_Table]:
        value = self.data.get(name, [])
        if not isinstance(value, list):
            raise self.loader.error(
                self.key(name),
                f"must be an array of tables ([[{self.key(name)}]]), not {_describe(value)}",
            )
        return [
            _Table(self.loader, f"{self.key(name)}[{i}]", item, accepted)
            for i, item in enumerate(value)
        ]

    def build(self, cls: type[_T], **kwargs: Any) -> _T:
        """``cls(**kwargs)``, its own validation errors re-addressed to this table."""
        try:
            return cls(**kwargs)
        except WorldError as exc:
            raise self.loader.error(self.key(exc.key), exc.problem) from None


def _describe(value: object) -> str:
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"the array {value!r}"
    return f"{type(value).__name__} {value!r}"


class _Loader:
    """Turns parsed TOML into a :class:`WorldConfig`, one section at a time."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, key: str, problem: str) -> WorldError:
        return WorldError(self.source, key, problem)

    def world(self, data: dict[str, Any]) -> WorldConfig:
        root = _Table(self, "", data, _TOP_KEYS)
        world = self.simple(root, "world", WorldSettings)
        quadrotor = self.simple(root, "quadrotor", QuadrotorParams)
        fixed_wing = self.fixed_wing(root.table("fixed_wing", _field_names(FixedWingParams)))
        radio = self.radio(root.table("radio", _field_names(RadioConfig)))
        camera = self.simple(root, "camera", CameraConfig)
        safety = self.safety(root.table("safety", _field_names(SafetyConfig)))
        fleet = self.fleet(root.table("fleet", (*_field_names(FleetConfig), "groups")))
        vehicles = tuple(
            self.vehicle(t) for t in root.tables("vehicles", _field_names(VehicleEntry))
        )
        targets = tuple(self.target(t) for t in root.tables("targets", _field_names(TargetConfig)))
        areas = tuple(self.area(t) for t in root.tables("areas", ("name", "rect", "polygon")))
        return root.build(
            WorldConfig,
            world=world,
            fleet=fleet,
            vehicles=vehicles,
            quadrotor=quadrotor,
            fixed_wing=fixed_wing,
            targets=targets,
            areas=areas,
            radio=radio,
            camera=camera,
            safety=safety,
            source=self.source,
        )

    def simple(self, root: _Table, name: str, cls: type[_T]) -> _T:
        """A section whose keys are all numbers, one per field of ``cls``."""
        table = root.table(name, _field_names(cast(type[Any], cls)))
        return table.build(cls, **{key: table.number(key) for key in table.data})

    def fixed_wing(self, table: _Table) -> FixedWingParams:
        kwargs: dict[str, Any] = {
            key: table.boolean(key) if key == "loiter_clockwise" else table.number(key)
            for key in table.data
        }
        return table.build(FixedWingParams, **kwargs)

    def radio(self, table: _Table) -> RadioConfig:
        kwargs: dict[str, Any] = {
            key: table.boolean(key) if key == "relay" else table.number(key) for key in table.data
        }
        return table.build(RadioConfig, **kwargs)

    def safety(self, table: _Table) -> SafetyConfig:
        kwargs: dict[str, Any] = {}
        if table.has("ceiling"):
            kwargs["ceiling"] = table.number("ceiling")
        if table.has("fatal_separation"):
            kwargs["fatal_separation"] = table.boolean("fatal_separation")
        return table.build(SafetyConfig, **kwargs)

    def kind(self, table: _Table, name: str) -> Kind:
        value = table.string(name)
        if value not in KINDS:
            raise self.error(
                table.key(name),
                f"unknown vehicle kind {value!r}{did_you_mean(value, KINDS)}; "
                f"kinds: {_list(KINDS)}",
            )
        return value

    def fleet(self, table: _Table) -> FleetConfig:
        kwargs: dict[str, Any] = {}
        for key in ("spacing", "heading", "battery"):
            if table.has(key):
                kwargs[key] = table.number(key)
        if table.has("kind"):
            kwargs["kind"] = self.kind(table, "kind")
        if table.has("platforms"):
            kwargs["platforms"] = table.platforms("platforms")
        if table.has("origin"):
            kwargs["origin"] = table.point("origin", (2,))
        if table.has("columns"):
            kwargs["columns"] = table.integer("columns")
        groups = []
        for group in table.tables("groups", _field_names(FleetGroup)):
            for required in ("platforms", "kind"):
                if not group.has(required):
                    raise self.error(group.key(required), "is required")
            extra = {k: group.number(k) for k in ("heading", "battery") if group.has(k)}
            groups.append(
                group.build(
                    FleetGroup,
                    platforms=group.platforms("platforms"),
                    kind=self.kind(group, "kind"),
                    **extra,
                )
            )
        return table.build(FleetConfig, groups=tuple(groups), **kwargs)

    def vehicle(self, table: _Table) -> VehicleEntry:
        if not table.has("platform"):
            raise self.error(table.key("platform"), "is required")
        kwargs: dict[str, Any] = {"platform": table.integer("platform")}
        if table.has("kind"):
            kwargs["kind"] = self.kind(table, "kind")
        if table.has("home"):
            kwargs["home"] = table.point("home", (2,))
        for key in ("heading", "battery"):
            if table.has(key):
                kwargs[key] = table.number(key)
        return table.build(VehicleEntry, **kwargs)

    def target(self, table: _Table) -> TargetConfig:
        for required in ("name", "route", "speed"):
            if not table.has(required):
                raise self.error(table.key(required), "is required")
        route = tuple(
            (p[0], p[1], p[2] if len(p) == 3 else 0.0) for p in table.points("route", (2, 3))
        )
        kwargs: dict[str, Any] = {
            "name": table.string("name"),
            "route": route,
            "speed": table.number("speed"),
        }
        if table.has("kind"):
            kwargs["kind"] = table.string("kind")
        if table.has("loop"):
            kwargs["loop"] = table.boolean("loop")
        if table.has("start"):
            kwargs["start"] = table.number("start")
        return table.build(TargetConfig, **kwargs)

    def area(self, table: _Table) -> Area:
        if not table.has("name"):
            raise self.error(table.key("name"), "is required")
        name = table.string("name")
        if table.has("rect") == table.has("polygon"):
            raise self.error(
                table.path,
                'needs exactly one of "rect" ([x_min, y_min, x_max, y_max]) or '
                '"polygon" ([[x, y], ...])',
            )
        if table.has("rect"):
            x_min, y_min, x_max, y_max = table.point("rect", (4,))
            try:
                return Area.rect(name, x_min, y_min, x_max, y_max)
            except WorldError as exc:
                raise self.error(table.key(exc.key), exc.problem) from None
        polygon = tuple((p[0], p[1]) for p in table.points("polygon", (2,)))
        return table.build(Area, name=name, polygon=polygon)
