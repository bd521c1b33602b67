"""The formation plugins (docs/design.md §6): fly a slot of a shape that follows a moving leader.

``formation.arrow`` (:class:`Arrow`)
    One V, the leader at its tip, its arms opening backwards.
``formation.two_arrows`` (:class:`TwoArrows`)
    Two Vs side by side, the leader at the tip of the left one.
``formation.line`` (:class:`Line`)
    A line abreast, the leader in the middle.
``formation.six_arrows`` (:class:`SixArrows`)
    Six small Vs, their tips laid out as a V of Vs.
``formation.herringbone`` (:class:`Herringbone`)
    A spine along the direction of flight with two-slot ribs swept back on both sides.
``formation.circle`` (:class:`Circle`)
    A ring around the leader.
``formation.grid`` (:class:`Grid`)
    Rows abreast, one behind the other, the leader in the middle of the front row.

Theory of operation
-------------------
Three layers, each usable on its own:

* **Geometry.** :func:`slots` gives the ``(n, 2)`` offsets of a shape in the *formation
  frame* (x forward, y to the left, metres), slot 1 at the leader's position ``(0, 0)``.
  Every shape keeps every pair of slots at least ``spacing`` apart, for any ``n``; the
  composite shapes (two arrows, six arrows) place their sub-formations on a pitch larger
  than a sub-formation's bounding box plus ``spacing``, which is what guarantees it.
  A shape depends on ``n`` only where it must (the number of arrows a slot falls in, the
  radius of the ring, the width of the grid), so every member must be given the same
  ``size``. :func:`to_world` rotates offsets by the heading (radians, counter-clockwise
  from x, the mission frame's east) and moves them to the leader.
* **A virtual leader.** :class:`VirtualLeader` is a point that flies a route of straight
  segments at constant speed from ``start_time``: a pure function of time, so every member
  computes the same leader from its own clock without talking to the others (``depart``
  counts from the task's start, which every platform knows on the clock it shares with
  the others: ``ctx.task_start``). It stops at
  the last point, or loops back to the first. Its heading is the direction of the segment
  it is on (the last segment's once stopped; 0, east, for a route of one point), so the
  formation turns as a whole at each waypoint.
* **The plugin.** Each member's :class:`Formation` reads its slot from ``ctx.slot`` (the
  1-based place the master scattered when the group switched the actor in; 0, no slot,
  flies slot 1), and on every step steers the vehicle by its slot's point: the leader's
  position now plus the rotated offset, at ``altitude``. While the leader moves, the
  member aims at a *carrot* ``lookahead`` seconds of leader travel ahead of its slot and
  asks for the leader's ``speed`` plus what closes the along-track gap to the slot in
  :data:`CATCH_UP_TIME` seconds (the vehicle clamps that to what it can fly). Aiming ahead
  is what lets a fixed-wing keep a moving slot: a vehicle sent to the slot itself would
  reach it and start circling it, while one chasing a point ahead flies parallel to the
  leader and settles on the slot's line. Once the leader stops, the member goes to the
  slot itself. A command is re-sent only when the aimed point moved at least
  :data:`RECOMMAND_DISTANCE` from the one last sent, so a formation at rest costs a
  comparison per step. A vehicle on the ground takes off on the way (what a ``goto``
  does).

  The route's progress is a function of time, so the snapshot is just the time the leader
  set off, ``{"start": t}``: a restored instance re-reads its params in ``on_activate``
  and the whole group stays on the same leader. ``on_pause`` sends nothing (the actor
  that preempted this one owns the autopilot); ``on_activate`` sends the slot's point
  again.

Which member takes which slot is the master's choice when it releases the group: by
:meth:`Formation.group_points` it knows where the slots are, by the requests where the
members are, and it hands out the slots by least total squared distance, so that members
closing on their slots in step keep apart (:mod:`actorswarm.engine.assign`). The plugins
do not steer around each other beyond that, since they do not know where the others are;
two things separate them vertically. ``altitude_step`` gives every slot a layer of its own
(small steps: it separates members on their slots, not members crossing). ``transit_step``
deconflicts the changes of shape, when paths cross and converge: a member further than half
the spacing from its slot flies one of
:data:`~actorswarm.plugins.flight.TRANSIT_LAYERS` transit layers, ``transit_step`` apart,
half below the formation's altitude and half above, none at it (slot ``k`` on layer
``(k - 1) mod TRANSIT_LAYERS``, so members with neighbouring slots are on different
layers, and every member in transit passes at least a step above or below the members
already on their slots), and goes back to its slot's altitude once within a quarter of the
spacing. With a step at least the vehicles' separation, two members in transit on
different layers cannot breach it; two on one layer still can, and so can one climbing or
descending through another's layer. ``transit_hold`` takes the climbs and descents of a
join off the way: members that arrive on altitudes of their own (take-off layers) keep
them until near their slots. How close they come is measured in every run
(:mod:`actorswarm.world.separation`; docs/safety.md gives the figures of the shipped
missions).
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Final

import numpy as np
from numpy.typing import NDArray

from actorswarm.plugins.flight import TRANSIT_LAYERS
from actorswarm.plugins.snapshot import finite
from actorswarm.runtime.builtin import EVENT_NAME_FORM, EVENT_NAME_PATTERN
from actorswarm.runtime.plugin import Param, Plugin, Point
from actorswarm.runtime.shapes import read_route

if TYPE_CHECKING:
    from actorswarm.runtime.context import PluginContext

__all__ = [
    "CATCH_UP_TIME",
    "RECOMMAND_DISTANCE",
    "ROUTE_PATTERN",
    "SHAPES",
    "TRANSIT_ENTER",
    "TRANSIT_LAYERS",
    "TRANSIT_LEAVE",
    "Arrow",
    "Circle",
    "Formation",
    "Grid",
    "Herringbone",
    "Line",
    "SixArrows",
    "TwoArrows",
    "VirtualLeader",
    "departure",
    "parse_route",
    "slots",
    "to_world",
    "transit_altitude",
]

FloatArray = NDArray[np.float64]

#: A slot's point that moved less than this (metres) since the last command is not re-sent.
RECOMMAND_DISTANCE: Final = 1.0
#: With ``transit_step``, a member further than this share of the spacing from its slot
#: flies a transit layer, until it is within :data:`TRANSIT_LEAVE` of the spacing again.
TRANSIT_ENTER: Final = 0.5
TRANSIT_LEAVE: Final = 0.25
#: The commanded speed closes the distance to the slot in about this many seconds, on top
#: of the leader's speed.
CATCH_UP_TIME: Final = 5.0

#: The half-angle of an arrow's V (between an arm and the backward axis).
_ARROW_HALF_ANGLE: Final = math.radians(40.0)
#: The angle of a herringbone rib from the backward axis, and the spine's pitch in spacings.
_RIB_ANGLE: Final = math.radians(60.0)
_SPINE_PITCH: Final = 1.5
_RIB_LENGTH: Final = 2
#: Steps along a slanted arm or a ring are stretched by this factor, so that rounding in
#: the trigonometry never brings two slots under the spacing.
_MARGIN: Final = 1.0 + 1e-9


def _arrow(n: int, spacing: float) -> FloatArray:
    """One V: slot 1 at the tip, then rank by rank alternately left and right, ``spacing``
    apart along each arm."""
    out = np.zeros((n, 2))
    step = spacing * _MARGIN
    back, side = math.cos(_ARROW_HALF_ANGLE) * step, math.sin(_ARROW_HALF_ANGLE) * step
    for k in range(1, n):
        rank = (k + 1) // 2
        out[k] = (-rank * back, rank * side if k % 2 else -rank * side)
    return out


def _line(n: int, spacing: float) -> FloatArray:
    """Abreast: slot 1 in the middle, then alternately left and right."""
    out = np.zeros((n, 2))
    for k in range(1, n):
        rank = (k + 1) // 2
        out[k, 1] = rank * spacing if k % 2 else -rank * spacing
    return out


def _extent(offsets: FloatArray) -> tuple[float, float]:
    """The depth (x) and width (y) of the offsets' bounding box."""
    if not len(offsets):
        return 0.0, 0.0
    span = offsets.max(axis=0) - offsets.min(axis=0)
    return float(span[0]), float(span[1])


def _split(n: int, parts: int) -> list[int]:
    """``n`` slots into ``parts`` groups as even as can be, the larger ones first."""
    return [n // parts + (1 if j < n % parts else 0) for j in range(parts)]


def _tiled(
    n: int, spacing: float, parts: int, tips: Callable[[int, float, float], FloatArray]
) -> FloatArray:
    """``parts`` arrows holding the slots in order (the first ones in the first arrow),
    the arrows' tips at ``tips(parts, pitch_x, pitch_y)``. The pitches are a sub-arrow's
    bounding box plus ``spacing``, so tips that differ by a whole pitch in x or in y keep
    every slot of one arrow ``spacing`` from every slot of the other."""
    sizes = [size for size in _split(n, parts) if size]
    template = _arrow(max(sizes), spacing)
    depth, width = _extent(template)
    origins = tips(len(sizes), (depth + spacing) * _MARGIN, (width + spacing) * _MARGIN)
    return np.concatenate(
        [_arrow(size, spacing) + origins[j] for j, size in enumerate(sizes)], axis=0
    )


def _side_by_side(count: int, _pitch_x: float, pitch_y: float) -> FloatArray:
    return np.array([(0.0, -j * pitch_y) for j in range(count)])


def _arrow_of_tips(count: int, pitch_x: float, pitch_y: float) -> FloatArray:
    out = np.zeros((count, 2))
    for j in range(1, count):
        rank = (j + 1) // 2
        out[j] = (-rank * pitch_x, rank * pitch_y if j % 2 else -rank * pitch_y)
    return out


def _two_arrows(n: int, spacing: float) -> FloatArray:
    return _tiled(n, spacing, 2, _side_by_side)


def _six_arrows(n: int, spacing: float) -> FloatArray:
    return _tiled(n, spacing, 6, _arrow_of_tips)


def _herringbone(n: int, spacing: float) -> FloatArray:
    """Rows of ``1 + 2·_RIB_LENGTH`` slots: the spine's slot, then the ribs' slots
    alternately left and right, each ``spacing`` further out and swept back."""
    per_row = 1 + 2 * _RIB_LENGTH
    step = spacing * _MARGIN
    back, side = math.cos(_RIB_ANGLE) * step, math.sin(_RIB_ANGLE) * step
    out = np.zeros((n, 2))
    for k in range(n):
        row, place = divmod(k, per_row)
        x0 = -row * _SPINE_PITCH * spacing
        if place == 0:
            out[k] = (x0, 0.0)
        else:
            reach = (place + 1) // 2
            out[k] = (x0 - reach * back, reach * side if place % 2 else -reach * side)
    return out


def _circle(n: int, spacing: float) -> FloatArray:
    """The leader at the centre, the others on a ring starting straight ahead,
    counter-clockwise; the radius keeps both the chord and the radius ≥ ``spacing``."""
    out = np.zeros((n, 2))
    ring = n - 1
    if ring < 1:
        return out
    radius = spacing if ring < 2 else max(spacing, spacing / (2.0 * math.sin(math.pi / ring)))
    radius *= _MARGIN
    for k in range(ring):
        angle = 2.0 * math.pi * k / ring
        out[k + 1] = (radius * math.cos(angle), radius * math.sin(angle))
    return out


def _grid(n: int, spacing: float) -> FloatArray:
    """``ceil(sqrt(n))`` columns, rows behind one another; in each row the columns go
    middle, left, right, further left, ..."""
    columns = math.isqrt(n - 1) + 1 if n > 1 else 1
    out = np.zeros((n, 2))
    for k in range(n):
        row, column = divmod(k, columns)
        rank = (column + 1) // 2
        out[k] = (-row * spacing, rank * spacing if column % 2 else -rank * spacing)
    return out


_SHAPES: Final[Mapping[str, Callable[[int, float], FloatArray]]] = {
    "arrow": _arrow,
    "two_arrows": _two_arrows,
    "line": _line,
    "six_arrows": _six_arrows,
    "herringbone": _herringbone,
    "circle": _circle,
    "grid": _grid,
}
#: The shape names :func:`slots` knows.
SHAPES: Final[tuple[str, ...]] = tuple(_SHAPES)


def slots(shape: str, n: int, spacing: float) -> FloatArray:
    """The ``(n, 2)`` offsets of ``n`` slots of ``shape`` in the formation frame (x
    forward, y left, metres): row ``k - 1`` is slot ``k``, slot 1 is ``(0, 0)``, and every
    two slots are at least ``spacing`` apart. ValueError for an unknown shape, ``n < 1`` or
    a ``spacing`` that is not a positive finite number."""
    build = _SHAPES.get(shape)
    if build is None:
        raise ValueError(f"unknown formation shape {shape!r}; the shapes are {', '.join(SHAPES)}")
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"a formation needs n ≥ 1 slots, not {n!r}")
    if not (finite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be a positive number of metres, not {spacing!r}")
    return build(n, float(spacing))


def to_world(offsets: FloatArray, leader_xy: Sequence[float], heading_rad: float) -> FloatArray:
    """Formation-frame ``offsets`` (``(n, 2)``, or one ``(2,)``) in the mission frame: rotated
    counter-clockwise by ``heading_rad`` (the direction x forward points, from east) and
    moved to ``leader_xy``."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    rotation = np.array([[c, -s], [s, c]])
    points = np.asarray(offsets, dtype=np.float64)
    out: FloatArray = points @ rotation.T + np.asarray(leader_xy[:2], dtype=np.float64)
    return out


def transit_altitude(altitude: float, layer: int, layers: int, step: float) -> float:
    """The altitude of transit layer ``layer`` (0-based) of ``layers``, ``step`` metres
    apart around a formation flying at ``altitude``: half of them below, half above, none
    at it, so a member in transit passes at least one step above or below the members on
    their slots. Layer 0 is the lowest and ``layers - 1`` the highest."""
    half = layers // 2
    level = layer - half if layer < half else layer - half + 1
    return altitude + level * step


class VirtualLeader:
    """A point that flies ``route`` (``(x, y, z)`` points, metres) in straight segments at
    ``speed`` m/s, setting off from the first point at ``start_time`` seconds.

    Before ``start_time`` it is at the first point. It stops at the last point, or with
    ``loop`` flies back to the first and round again forever. Consecutive repeated points
    are one point. :meth:`position` and :meth:`heading` are pure functions of time.
    """

    def __init__(
        self,
        route: Sequence[Sequence[float]],
        speed: float,
        start_time: float = 0.0,
        *,
        loop: bool = False,
    ) -> None:
        points: list[Point] = []
        for i, p in enumerate(route):
            if len(p) != 3 or not all(finite(v) for v in p):
                raise ValueError(f"route point {i + 1} must be three finite numbers, not {p!r}")
            point = (float(p[0]), float(p[1]), float(p[2]))
            if not points or point != points[-1]:
                points.append(point)
        if not points:
            raise ValueError("a route needs at least one point")
        if not (finite(speed) and speed > 0):
            raise ValueError(f"speed must be a positive number (m/s), not {speed!r}")
        if not finite(start_time):
            raise ValueError(f"start_time must be a finite number of seconds, not {start_time!r}")
        if loop and len(points) > 1 and points[0] != points[-1]:
            points.append(points[0])
        self.route: tuple[Point, ...] = tuple(points)
        self.speed = float(speed)
        self.start_time = float(start_time)
        self.loop = loop and len(points) > 1
        # Plain floats (the same sums numpy's running sum gives): a member asks where the
        # leader is several times per step, and bisect on a tuple is many times faster
        # than numpy's searchsorted on an array of a few elements.
        self._ends: tuple[float, ...] = tuple(
            np.cumsum([0.0] + [math.dist(a, b) for a, b in itertools.pairwise(points)]).tolist()
        )
        # The last question and its answer: a step asks _locate for the same t up to four
        # times (slot point, heading, moving, heading again).
        self._located: tuple[float, int, float] | None = None
        # Each segment's heading, once asked for (the route never changes).
        self._headings: dict[int, float] = {}

    @property
    def length(self) -> float:
        """The route's length, metres (one lap, when looping)."""
        return self._ends[-1]

    def _locate(self, t: float) -> tuple[int, float]:
        """The segment the leader is on at ``t`` and how far along it (metres); segment
        ``-1`` for a route of one point."""
        located = self._located
        if located is not None and located[0] == t:
            return located[1], located[2]
        if len(self.route) < 2:
            return -1, 0.0
        ends = self._ends
        travelled = max(0.0, t - self.start_time) * self.speed
        if self.loop:
            travelled %= ends[-1]
        elif travelled >= ends[-1]:
            last = len(self.route) - 2
            along = ends[-1] - ends[-2]
            self._located = (t, last, along)
            return last, along
        # bisect_right is searchsorted(side="right"): the same segment, ties included.
        segment = bisect.bisect_right(ends, travelled) - 1
        segment = min(max(segment, 0), len(self.route) - 2)
        along = travelled - ends[segment]
        self._located = (t, segment, along)
        return segment, along

    def position(self, t: float) -> Point:
        """Where the leader is at ``t`` seconds."""
        segment, along = self._locate(t)
        if segment < 0:
            return self.route[0]
        a, b = self.route[segment], self.route[segment + 1]
        f = along / (self._ends[segment + 1] - self._ends[segment])
        return (a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f)

    def heading(self, t: float) -> float:
        """The leader's heading at ``t``: radians counter-clockwise from east, of the
        segment it is on (of the last one once stopped; 0 for a route of one point). A
        vertical segment keeps the heading of the segment before it."""
        segment, _ = self._locate(t)
        heading = self._headings.get(segment)
        if heading is None:
            heading = self._headings[segment] = self._segment_heading(segment)
        return heading

    def _segment_heading(self, segment: int) -> float:
        for k in range(segment, -1, -1):
            a, b = self.route[k], self.route[k + 1]
            if a[0] != b[0] or a[1] != b[1]:
                return math.atan2(b[1] - a[1], b[0] - a[0])
        return 0.0

    def moving(self, t: float) -> bool:
        """Whether the leader is on its way at ``t`` (not waiting, not stopped)."""
        if len(self.route) < 2 or t < self.start_time:
            return False
        return self.loop or (t - self.start_time) * self.speed < self.length


_NUMBER: Final = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_WAYPOINT: Final = rf"\s*{_NUMBER}\s+{_NUMBER}\s*"
#: What a ``route`` param looks like: ``x y`` pairs separated by ``;``.
ROUTE_PATTERN: Final = rf"{_WAYPOINT}(?:;{_WAYPOINT})*;?\s*"


def parse_route(text: str, altitude: float) -> list[Point]:
    """The waypoints of ``"x1 y1; x2 y2; ..."`` (metres) at ``altitude``. ValueError naming
    the waypoint for anything else (:func:`~actorswarm.runtime.shapes.read_route`)."""
    return [(x, y, float(altitude)) for x, y in read_route(text)]


def departure(depart: Any, now: float, task_start: float | None) -> float:
    """When the leader sets off, on the clock of ``now``: ``depart`` seconds after the
    task's start (``task_start``; taken as 0 where no start is known), or ``now`` when no
    ``depart`` is given (it sets off as the actor starts)."""
    if depart is None:
        return now
    return (0.0 if task_start is None else task_start) + float(depart)


def _positive(name: str, params: Mapping[str, Any], key: str) -> float:
    value = float(params[key])
    if not value > 0:
        raise ValueError(f"{name}: {key} must be > 0, not {value:g}")
    return value


class Formation(Plugin):
    """A member of a formation of shape :attr:`shape` following a virtual leader (module
    docstring). One subclass per shape; this base is not registered itself.

    Params:

    ``spacing`` (float > 0, default 20)
        Metres between neighbouring slots: the least distance between any two slots.
    ``speed`` (float > 0, default 10)
        The leader's ground speed along the route, m/s. A member asks for more when it
        is behind its slot, as much as its vehicle can fly.
    ``altitude`` (float > 0, default 30)
        The formation's altitude, metres above the ground.
    ``route`` (default ``"0 0"``)
        The leader's waypoints, ``"x1 y1; x2 y2; ..."`` metres. The leader starts at the
        first when the actor starts and flies the others in order; the first point of
        the route is where the formation gathers.
    ``altitude_step`` (float ≥ 0, default 0)
        Slot ``k`` flies at ``altitude + (k - 1) · altitude_step``. Members fly straight to
        their slots and may cross each other's paths on the way; a step of a few metres
        puts every member on a layer of its own, so crossing paths pass above each other.
    ``transit_step`` (float ≥ 0, default 0)
        While far from its slot (changing shape), fly a transit layer: ``transit_step``
        metres apart, by slot (module docstring). 0: no transit layers. A step of at least
        the vehicles' separation keeps members on different layers apart.
    ``transit_layers`` (int ≥ 0, default :data:`TRANSIT_LAYERS`)
        How many transit layers (half below the altitude, half above, none at it); 0: one
        per member of the group, so that no two members in transit share one — for aircraft
        that follow their slots loosely (real fixed-wings), where two on one layer meet.
    ``transit_hold`` (bool, default false)
        A member that leaves for its slot from ``transit_step`` or more above or below the
        slot's altitude (a take-off layer) flies there at the altitude it has, not on a
        transit layer, and climbs or descends only within a quarter of the spacing of its
        slot. For members that arrive on altitudes of their own (``flight.takeoff`` with
        ``layers``): going to a transit layer, each would cross the others' altitudes
        where their paths converge. Members that share an altitude must not use it.
    ``loop`` (bool, default false)
        Fly the route round and round (back from the last point to the first) instead of
        stopping at the last point.
    ``event`` (optional; left out: none)
        The arrival event (the paper's ``arriving_event`` at the end of an ingress): emitted
        once per start, local scope, on the first step at which the leader has stopped at
        the route's last point and this member is within ``tolerance`` metres of its slot.
        A looping route never ends, so it never fires there.
    ``tolerance`` (float ≥ 0, default 5)
        Metres from the slot that count as arrived.
    ``lookahead`` (float ≥ 0, default 4)
        While the leader moves, aim ``lookahead · speed`` metres ahead of the slot (module
        docstring); 0 aims at the slot itself, which suits only vehicles that can hover.
    ``size`` (int ≥ 0, default 0)
        The number of slots, the same for every member: the shape of the composite
        formations depends on it. 0: the number of platforms the switching firing sent to
        this actor (``ctx.slots``), which is what a group wants; give a number to keep a
        shape whatever the group's size. A member whose slot is above ``size`` refuses to
        start.
    ``depart`` (float, optional)
        When the leader sets off from the route's first point: seconds after the task's
        start (``ctx.task_start``: the ground station's ``start``, one instant for every
        platform, on the clock they share — the simulator's, or GPS/NTP time on robots).
        Left out: when the actor starts. Giving several formation actors the same
        ``route`` and ``depart`` makes them follow **one** leader: the swarm changes shape
        without leaving its path.
    ``offset`` (default ``"0 0"``)
        ``"forward left"`` metres: this formation's own leader is that far from the route's
        leader, in the formation frame. Two sub-swarms on one route fly side by side.

    The slot is ``ctx.slot`` — the place among the platforms the firing sent to this actor,
    counted by the master across every part of a merge — and 1 when the actor was not
    switched in by a group. A member switched back in (re-activated) by a new firing takes
    its new slot on the same leader. The snapshot is the time the leader set off, the same
    counted from the task's start, and whether the arrival event went out: ``{"start": t,
    "after_task": s, "arrived": bool}``. A platform restored after a reboot (a new clock)
    puts the leader ``after_task`` seconds after the task's start on its new clock.
    """

    bus = "act_bus"
    resources = frozenset({"autopilot"})
    needs_vehicle = True
    group_in_step = True
    #: The :func:`slots` shape this class flies.
    shape: ClassVar[str] = "arrow"
    params: ClassVar[Mapping[str, Param]] = {
        "spacing": Param(
            kind="float",
            default=20.0,
            minimum=0.0,
            doc="metres between neighbouring slots, the least distance between two (> 0)",
        ),
        "speed": Param(
            kind="float",
            default=10.0,
            minimum=0.0,
            doc="the leader's ground speed along the route, m/s (> 0)",
        ),
        "altitude": Param(
            kind="float",
            default=30.0,
            minimum=0.0,
            doc="the formation's altitude, metres above the ground (> 0)",
        ),
        "route": Param(
            kind="route",
            default="0 0",
            doc="the leader's waypoints, 'x1 y1; x2 y2; ...' metres, flown in order",
        ),
        "altitude_step": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="metres of altitude between consecutive slots' layers (slot k flies at "
            "altitude + (k - 1) * altitude_step); 0: one layer",
        ),
        "loop": Param(
            kind="bool",
            default=False,
            doc="fly the route round and round instead of stopping at its last point",
        ),
        "event": Param(
            kind="str",
            pattern=EVENT_NAME_PATTERN,
            form=EVENT_NAME_FORM,
            doc="emitted once (local scope) when the leader has reached the route's end and "
            "this member is within tolerance of its slot; left out: none",
        ),
        "tolerance": Param(
            kind="float",
            default=5.0,
            minimum=0.0,
            doc="metres from the slot that count as arrived (for event)",
        ),
        "lookahead": Param(
            kind="float",
            default=4.0,
            minimum=0.0,
            doc="while the leader moves, aim this many seconds of leader travel ahead of "
            "the slot (0: at the slot itself)",
        ),
        "size": Param(
            kind="int",
            default=0,
            minimum=0,
            doc="the number of slots, the same for every member; 0: as many as the firing "
            "sent to this actor",
        ),
        "depart": Param(
            kind="float",
            doc="when the leader sets off from the route's first point, seconds after the "
            "task's start (one instant for the whole swarm); left out: when the actor starts",
        ),
        "offset": Param(
            kind="str",
            default="0 0",
            pattern=rf"\s*{_NUMBER}\s+{_NUMBER}\s*",
            form="two numbers 'forward left' in metres, such as '0 -30'",
            doc="'forward left' metres from the route's leader to this formation's leader",
        ),
        "transit_step": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="metres between the transit layers a member flies while far from its slot "
            "(slot k on layer (k - 1) mod transit_layers, half below the altitude, half "
            "above); 0: none",
        ),
        "transit_layers": Param(
            kind="int",
            default=TRANSIT_LAYERS,
            minimum=0,
            doc="how many transit layers; 0: one per member of the group",
        ),
        "transit_hold": Param(
            kind="bool",
            default=False,
            doc="a member that leaves for its slot from at least transit_step above or "
            "below the slot's altitude keeps the altitude it has on the way instead of a "
            "transit layer, and changes height only near its slot (members that arrive "
            "on layers of their own: flight.takeoff's)",
        ),
    }

    def __init__(self) -> None:
        self._start: float | None = None
        #: The leader's start counted from the task's start (None: no task start known).
        self._after_task: float | None = None
        self._leader: VirtualLeader | None = None
        self._offset: FloatArray = np.zeros(2)
        #: The offset rotated by each heading the leader has had (slot_point), by heading.
        self._rotated: dict[float, tuple[float, float]] = {}
        self._altitude = 0.0
        self._speed = 0.0
        self._slot = 0
        self._arrived = False
        self._sent: tuple[float, float, float] | None = None
        self._base = 0.0
        self._spacing = 0.0
        #: The transit layer flown now (a multiple of transit_step), None: the slot's own.
        self._layer: int | None = None
        self._layers = TRANSIT_LAYERS
        self._held: float | None = None

    @classmethod
    def group_points(
        cls,
        params: Mapping[str, Any],
        count: int,
        now: float,
        areas: Mapping[str, Sequence[tuple[float, float]]],
        *,
        task_start: float | None = None,
    ) -> list[tuple[float, float]] | None:
        """The points of slots ``1..count`` at ``now`` (x, y metres): where the leader is
        then (from ``depart``, or setting off now) plus each slot's offset — what the
        master assigns the group's members to by least total distance."""
        size = int(params["size"]) or count
        if size < count:
            return None
        name = cls.entry_name()
        speed = _positive(name, params, "speed")
        start = departure(params["depart"], now, task_start)
        route = parse_route(str(params["route"]), 0.0)
        leader = VirtualLeader(route, speed, start, loop=bool(params["loop"]))
        forward, left = (float(v) for v in str(params["offset"]).split())
        offsets = slots(cls.shape, size, _positive(name, params, "spacing"))[:count]
        x, y, _ = leader.position(now)
        points = to_world(offsets + np.array([forward, left]), (x, y), leader.heading(now))
        return [(float(p[0]), float(p[1])) for p in points.tolist()]

    @classmethod
    def entry_name(cls) -> str:
        """The entry-point name this class is registered under (``formation.<shape>``)."""
        return f"formation.{cls.shape}"

    def _setup(self, ctx: PluginContext, start: float) -> None:
        name, params = self.entry_name(), ctx.params
        spacing = _positive(name, params, "spacing")
        self._speed = _positive(name, params, "speed")
        self._altitude = _positive(name, params, "altitude")
        self._base = self._altitude
        self._spacing = spacing
        self._layer = None
        self._held = None
        slot = ctx.slot if ctx.slot > 0 else 1
        size = int(params["size"]) or max(ctx.slots, slot)
        if slot > size:
            raise ValueError(
                f"{name}: this member's slot {slot} is beyond size {size}; give every member "
                "a size of at least the group's number of platforms (or 0: the group's)"
            )
        self._altitude += (slot - 1) * float(params["altitude_step"])
        self._layers = int(params["transit_layers"]) or size
        route = parse_route(str(params["route"]), self._altitude)
        self._leader = VirtualLeader(route, self._speed, start, loop=bool(params["loop"]))
        forward, left = (float(v) for v in str(params["offset"]).split())
        self._offset = slots(self.shape, size, spacing)[slot - 1] + np.array([forward, left])
        self._rotated = {}
        self._slot = slot
        self._start = start
        self._after_task = None if ctx.task_start is None else start - ctx.task_start
        self._sent = None

    def _departure(self, ctx: PluginContext) -> float:
        return departure(ctx.params["depart"], ctx.now, ctx.task_start)

    def slot_point(self, t: float) -> Point:
        """Where this member's slot is at ``t`` (after the start)."""
        if self._leader is None:
            raise RuntimeError(f"{self.entry_name()}: the formation is not set up (start it first)")
        x, y, _ = self._leader.position(t)
        heading = self._leader.heading(t)
        rotated = self._rotated.get(heading)
        if rotated is None:
            # The leader's heading is one per segment of its route, so the rotated offset
            # is too: computed once by to_world's own product (the same bits as before)
            # and then only moved to the leader, which is to_world's final addition.
            rx, ry = to_world(self._offset, (0.0, 0.0), heading).tolist()
            rotated = self._rotated[heading] = (float(rx), float(ry))
        return (rotated[0] + x, rotated[1] + y, self._altitude)

    def _command(self, ctx: PluginContext, *, force: bool) -> None:
        assert self._leader is not None
        vehicle = ctx.require_vehicle()
        slot = self.slot_point(ctx.now)
        position = vehicle.position()
        if self._leader.moving(ctx.now):
            heading = self._leader.heading(ctx.now)
            ux, uy = math.cos(heading), math.sin(heading)
            ahead = self._speed * float(ctx.params["lookahead"])
            target = (slot[0] + ux * ahead, slot[1] + uy * ahead, slot[2])
            behind = (slot[0] - position[0]) * ux + (slot[1] - position[1]) * uy
            speed = max(self._speed + behind / CATCH_UP_TIME, 0.1 * self._speed)
        else:
            target = slot
            speed = self._speed + math.dist(position, slot) / CATCH_UP_TIME
        z = self._transit(ctx, slot, position)
        target = (target[0], target[1], z)
        unchanged = self._sent is not None and math.dist(target, self._sent) < RECOMMAND_DISTANCE
        if unchanged and not force:
            return
        vehicle.goto(*target, speed=speed)
        self._sent = target

    def _transit(self, ctx: PluginContext, slot: Point, position: Point) -> float:
        """The altitude to fly at now: the slot's, or while far from it (more than half the
        spacing), the transit layer of the way it must go in the leader's frame — chosen
        when it leaves its slot's neighbourhood and kept until it is within a quarter of
        the spacing (so a member does not hop between layers on the way)."""
        step = float(ctx.params["transit_step"])
        assert self._leader is not None
        if step <= 0:
            return slot[2]
        ex, ey = slot[0] - position[0], slot[1] - position[1]
        far = math.hypot(ex, ey)
        if self._layer is not None and far < TRANSIT_LEAVE * self._spacing:
            self._layer = None
        elif self._layer is None and far > TRANSIT_ENTER * self._spacing:
            # Layers by slot: members whose slots are neighbours (in any shape, mostly a
            # few numbers apart) cross and converge on different layers.
            self._layer = (self._slot - 1) % self._layers
            # Arriving from an altitude of its own (a take-off layer): climbing or
            # descending to a transit layer on the way would cross the others' layers
            # where their paths converge; it changes height near its slot instead.
            hold = bool(ctx.params["transit_hold"]) and abs(position[2] - slot[2]) >= step
            self._held = position[2] if hold else None
        if self._layer is None:
            return slot[2]
        if self._held is not None:
            return self._held
        return transit_altitude(self._base, self._layer, self._layers, step)

    def on_start(self, ctx: PluginContext) -> None:
        self._arrived = False
        self._setup(ctx, self._departure(ctx))
        self._command(ctx, force=True)

    def step(self, ctx: PluginContext) -> None:
        self._command(ctx, force=False)
        event = ctx.params["event"]
        if event is None or self._arrived or self._leader is None or self._leader.moving(ctx.now):
            return
        if self._leader.loop:
            return
        slot = self.slot_point(ctx.now)
        if math.dist(ctx.require_vehicle().position(), slot) <= float(ctx.params["tolerance"]):
            self._arrived = True
            ctx.emit(event)

    def on_activate(self, ctx: PluginContext) -> None:
        if self._leader is None or (ctx.slot > 0 and ctx.slot != self._slot):
            # Restored from a snapshot, or switched back in by a firing that gave this
            # member another slot: rebuild from the params, keeping the leader's start —
            # counted from the task's start where both are known, since a platform that
            # rebooted has a new clock.
            if self._start is None:
                start = self._departure(ctx)
            elif self._after_task is not None and ctx.task_start is not None:
                start = ctx.task_start + self._after_task
            else:
                start = self._start
            self._setup(ctx, start)
        self._command(ctx, force=True)

    def snapshot(self) -> dict[str, Any]:
        return {"start": self._start, "after_task": self._after_task, "arrived": self._arrived}

    def restore(self, state: Mapping[str, Any]) -> None:
        start = state.get("start")
        if not finite(start):
            raise ValueError(
                f"{self.entry_name()}: a snapshot's 'start' must be a number of seconds, "
                f"not {start!r}"
            )
        assert isinstance(start, int | float)
        self._start = float(start)
        after = state.get("after_task")
        if after is not None and not finite(after):
            raise ValueError(
                f"{self.entry_name()}: a snapshot's 'after_task' must be a number of seconds "
                f"or null, not {after!r}"
            )
        self._after_task = None if after is None else float(after)
        arrived = state.get("arrived", False)
        if not isinstance(arrived, bool):
            raise ValueError(
                f"{self.entry_name()}: a snapshot's 'arrived' must be true or false, "
                f"not {arrived!r}"
            )
        self._arrived = arrived


class Arrow(Formation):
    """``formation.arrow``: one V opening backwards, the leader at its tip."""

    shape = "arrow"


class TwoArrows(Formation):
    """``formation.two_arrows``: two Vs side by side; slots ``1..ceil(size/2)`` in the left
    one (the leader's), the rest in the right one."""

    shape = "two_arrows"


class Line(Formation):
    """``formation.line``: a line abreast, the leader in the middle, then alternately
    left and right."""

    shape = "line"


class SixArrows(Formation):
    """``formation.six_arrows``: six small Vs (the slots split as evenly as can be, in
    order), their tips laid out as a V of Vs behind the leader's."""

    shape = "six_arrows"


class Herringbone(Formation):
    """``formation.herringbone``: a spine along the direction of flight, each spine slot
    with a rib of two slots swept back on either side."""

    shape = "herringbone"


class Circle(Formation):
    """``formation.circle``: the leader at the centre and the others on a ring around it,
    the ring's radius keeping neighbours ``spacing`` apart."""

    shape = "circle"


class Grid(Formation):
    """``formation.grid``: ``ceil(sqrt(size))`` columns abreast, rows one behind the other,
    the leader in the middle of the front row."""

    shape = "grid"
