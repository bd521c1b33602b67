"""The area-search plugin (docs/design.md §6): the searchers split an area and sweep it.

``search.area`` (:class:`AreaSearch`)
    The paper's *Range* actor: each searcher takes one strip of the area and flies it in a
    lawnmower pattern (up one lane, down the next) at ``altitude``, so that its camera sees
    every point of the strip; emits ``event`` (when given) once the strip has been swept.

Theory of operation
-------------------
Two layers, the first usable on its own:

* **Geometry.** :func:`strip_bounds` cuts the bounding box of an area (a polygon,
  ``(x, y)`` vertices, metres) into ``strips`` equal slices along x; strip ``k`` (1-based)
  is the ``k``-th from the west. :func:`lanes` lays the slice's lanes: the fewest evenly
  spaced lines along y that are at most ``lane`` metres apart and no more than ``lane / 2``
  from the slice's edges, so every point of the slice is within ``lane / 2`` of a lane's
  x. Each lane is the slab of the strip it stands for (``lane`` wide at most) clipped to
  the polygon: it runs from the lowest to the highest y the polygon reaches in that slab
  — for a rectangle, the whole height; for a slanted edge, far enough that a point of the
  polygon beside the lane's end is not missed. A slab the polygon does not reach gives no
  lane. The lanes are joined into one boustrophedon route: the first goes north, the next
  south, and so on, two waypoints each.
* **The plugin.** :class:`AreaSearch` takes strip ``ctx.slot`` of ``ctx.slots`` (1 of 1
  for an actor not switched in by a group: the whole area), computes its route once at
  start and flies it waypoint by waypoint: ``on_start`` sends the first ``goto``; a step
  that finds the vehicle within ``tolerance`` of the waypoint sends the next. After the
  last waypoint it emits ``event`` (once per start) and, with ``loop``, flies the route
  again backwards, and so on forever; without, it holds. A step never sends a command
  while nothing changed.

  The snapshot is the route and the index of the waypoint flown to, so a restored
  instance carries on where the other stopped, whatever params or group place it gets.
  ``on_pause`` sends nothing (the preempting actor owns the autopilot); ``on_activate``
  sends the current waypoint again.

Only the search's own strip is flown: splitting is static, so a searcher that drops out
leaves its strip unswept (a task script that cares re-switches the survivors, which
re-split the area among themselves).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Final

from actorswarm.plugins.snapshot import finite, read_point
from actorswarm.runtime.builtin import EVENT_NAME_FORM, EVENT_NAME_PATTERN
from actorswarm.runtime.plugin import Param, Plugin, Point
from actorswarm.runtime.shapes import read_rectangle
from actorswarm.suggest import did_you_mean

if TYPE_CHECKING:
    from actorswarm.runtime.context import PluginContext

__all__ = ["LANE_PER_ALTITUDE", "AreaSearch", "lanes", "parse_area", "strip_bounds"]

Polygon = Sequence[tuple[float, float]]

#: The default lane spacing per metre of search altitude: lanes ``2 × 0.8 × altitude``
#: apart leave no ground point further than ``0.8 × altitude`` from a lane, inside the
#: footprint of any downward camera of at least 2·atan(0.8) ≈ 77° field of view (the
#: simulated world's 90° camera sees ``altitude`` metres around).
LANE_PER_ALTITUDE: Final = 1.6

_NAME: Final = "search.area"


def parse_area(text: str, areas: Mapping[str, Polygon]) -> list[tuple[float, float]]:
    """The polygon ``text`` stands for: a rectangle ``"x_min y_min x_max y_max"``
    (metres), or the name of one of ``areas`` (the mission's named areas, ``ctx.areas``).
    ValueError for a malformed rectangle, an unknown name (with a suggestion and the names
    there are), or a named polygon that is not at least three finite vertices."""
    text = text.strip()
    rect = read_rectangle(text)
    if rect is not None:
        x0, y0, x1, y1 = rect
        return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    polygon = areas.get(text)
    if polygon is None:
        known = f"the areas are {', '.join(sorted(areas))}" if areas else "there are no areas"
        raise ValueError(
            f"{_NAME}: no area {text!r}{did_you_mean(text, areas)}; {known} (name one, or give "
            'a rectangle "x_min y_min x_max y_max")'
        )
    return _polygon(text, polygon)


def _polygon(name: str, polygon: Iterable[Sequence[float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for vertex in polygon:
        if len(vertex) != 2 or not all(finite(v) for v in vertex):
            raise ValueError(f"{_NAME}: area {name!r} has a vertex {vertex!r}; give (x, y) pairs")
        out.append((float(vertex[0]), float(vertex[1])))
    if len(out) < 3:
        raise ValueError(f"{_NAME}: area {name!r} needs at least 3 vertices, not {len(out)}")
    return out


def strip_bounds(polygon: Polygon, strip: int, strips: int) -> tuple[float, float]:
    """The x range ``(west, east)`` of strip ``strip`` (1-based) of ``strips`` equal
    slices of ``polygon``'s bounding box. Neighbouring strips share an edge, and together
    they are the box's x range exactly. ValueError for a strip out of range or a polygon
    of no width."""
    if isinstance(strips, bool) or not isinstance(strips, int) or strips < 1:
        raise ValueError(f"an area splits into strips ≥ 1, not {strips!r}")
    if isinstance(strip, bool) or not isinstance(strip, int) or not 1 <= strip <= strips:
        raise ValueError(f"strip must be 1..{strips}, not {strip!r}")
    xs = [float(x) for x, _ in polygon]
    if not xs or not all(math.isfinite(x) for x in xs):
        raise ValueError(f"an area is finite (x, y) vertices, not {list(polygon)!r}")
    west, east = min(xs), max(xs)
    if not east > west:
        raise ValueError(f"the area has no width (every vertex is at x = {west:g})")
    width = (east - west) / strips
    return west + (strip - 1) * width, east if strip == strips else west + strip * width


def _span(polygon: Polygon, lo: float, hi: float) -> tuple[float, float] | None:
    """The lowest and highest y of ``polygon`` between x = ``lo`` and x = ``hi``; None
    when it does not reach there. The extremes of a polygon cut by a slab are at its
    vertices inside the slab or where its edges cross the slab's sides."""
    ys: list[float] = []
    n = len(polygon)
    for i in range(n):
        (ax, ay), (bx, by) = polygon[i], polygon[(i + 1) % n]
        if lo <= ax <= hi:
            ys.append(ay)
        if ax == bx:
            continue
        for side in (lo, hi):
            if min(ax, bx) <= side <= max(ax, bx):
                ys.append(ay + (side - ax) * (by - ay) / (bx - ax))
    return (min(ys), max(ys)) if ys else None


def lanes(polygon: Polygon, strip: int, strips: int, lane: float, altitude: float) -> list[Point]:
    """The boustrophedon route of strip ``strip`` (1-based) of ``strips`` over
    ``polygon`` (module docstring): ``(x, y, altitude)`` waypoints, two per lane, the first
    lane flown north, lanes at most ``lane`` metres apart, every point of the polygon in
    the strip within ``lane / 2`` of a lane. Empty when the polygon does not reach into
    the strip. ValueError for a bad strip, ``lane`` or ``altitude``."""
    if not (finite(lane) and lane > 0):
        raise ValueError(f"lane must be a positive number of metres, not {lane!r}")
    if not finite(altitude):
        raise ValueError(f"altitude must be a finite number of metres, not {altitude!r}")
    west, east = strip_bounds(polygon, strip, strips)
    count = max(1, math.ceil((east - west) / lane - 1e-9))
    pitch = (east - west) / count
    route: list[Point] = []
    north = True
    for k in range(count):
        lo = west + k * pitch
        hi = east if k == count - 1 else lo + pitch
        span = _span(polygon, lo, hi)
        if span is None:
            continue
        x = (lo + hi) / 2.0
        ends = span if north else (span[1], span[0])
        for y in ends:
            point = (x, y, float(altitude))
            if not route or route[-1] != point:
                route.append(point)
        north = not north
    return route


def _read_route(state: Mapping[str, Any]) -> list[Point]:
    value = state.get("waypoints")
    if not isinstance(value, list) or not value:
        raise ValueError(
            f"{_NAME}: a snapshot's 'waypoints' must be a non-empty list of [x, y, z], "
            f"not {value!r}"
        )
    return [read_point(_NAME, "waypoints", point) for point in value]


class AreaSearch(Plugin):
    """``search.area``: sweep this member's strip of an area in a lawnmower pattern.

    Params:

    ``area`` (required)
        The area: the name of one of the mission's areas (``ctx.areas``: the world file's
        ``[[areas]]`` in the simulator), or a rectangle ``"x_min y_min x_max y_max"``
        (metres). An unknown name refuses the start, saying which names there are.
    ``altitude`` (float > 0, default 20)
        Metres above the ground to fly the lanes at.
    ``speed`` (float > 0, optional)
        Ground speed along the lanes, m/s; left out: the vehicle's cruise speed.
    ``lane`` (float ≥ 0, default 0)
        The most metres between neighbouring lanes. 0 means ``1.6 × altitude``
        (:data:`LANE_PER_ALTITUDE`): no point further than ``0.8 × altitude`` from a lane,
        which the simulated world's 90° camera (footprint radius = altitude) sees with a
        margin. Give it explicitly for a narrower camera.
    ``tolerance`` (float ≥ 0, default 3)
        How close to a waypoint (metres, straight-line) counts as reached.
    ``loop`` (bool, default true)
        When the strip is swept, sweep it again backwards, and so on; false: hold at the
        last waypoint.
    ``event`` (optional)
        Emitted once per start, scope local, when the last waypoint of the first sweep is
        reached. Left out: nothing is emitted.

    The strip is ``ctx.slot`` of ``ctx.slots`` (1 of 1, the whole area, when the actor was
    not switched in by a group); a strip the area does not reach is refused at start. A
    vehicle on the ground takes off on its way to the first waypoint (what a ``goto``
    does). The snapshot is ``{"waypoints": [[x, y, z], ...], "next": i, "done": bool}``:
    the route, the index of the waypoint being flown to (``len(waypoints)`` once a route
    without ``loop`` is finished) and whether the first sweep is over.
    """

    bus = "act_bus"
    resources = frozenset({"autopilot"})
    needs_vehicle = True
    params: ClassVar[Mapping[str, Param]] = {
        "area": Param(
            kind="area",
            required=True,
            doc="the area to search: a name from the mission's areas, or a rectangle "
            '"x_min y_min x_max y_max" (metres)',
        ),
        "altitude": Param(
            kind="float",
            default=20.0,
            minimum=0.0,
            doc="metres above the ground to fly the lanes at (> 0)",
        ),
        "speed": Param(
            kind="float",
            minimum=0.0,
            doc="ground speed in m/s (> 0); left out: the vehicle's cruise speed",
        ),
        "lane": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="the most metres between neighbouring lanes; 0: 1.6 × altitude",
        ),
        "tolerance": Param(
            kind="float",
            default=3.0,
            minimum=0.0,
            doc="metres from a waypoint that count as reached",
        ),
        "loop": Param(
            kind="bool",
            default=True,
            doc="sweep the strip again, backwards, each time it is done (false: hold)",
        ),
        "event": Param(
            kind="str",
            pattern=EVENT_NAME_PATTERN,
            form=EVENT_NAME_FORM,
            doc="the event to emit, once, when the strip has been swept the first time; "
            "left out: none",
        ),
    }

    def __init__(self) -> None:
        self._route: list[Point] = []
        self._next = 0
        self._done = False

    @property
    def route(self) -> tuple[Point, ...]:
        """The waypoints of the current sweep (empty before the start)."""
        return tuple(self._route)

    @property
    def next_index(self) -> int:
        """The index in :attr:`route` of the waypoint being flown to."""
        return self._next

    @property
    def done(self) -> bool:
        """Whether the strip has been swept once."""
        return self._done

    @staticmethod
    def resolve_lane(params: Mapping[str, Any]) -> float:
        """The lane spacing of ``params``: ``lane``, or ``1.6 × altitude`` when it is 0."""
        lane = float(params["lane"])
        return lane if lane > 0 else LANE_PER_ALTITUDE * float(params["altitude"])

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
        """Where strips ``1..count`` begin (each strip's first waypoint): the master hands
        the strips out by least total distance, so searchers do not cross the area to reach
        theirs. None when a strip has no lane (an area too narrow for that many)."""
        polygon = parse_area(str(params["area"]), areas)
        lane, altitude = cls.resolve_lane(params), float(params["altitude"])
        starts = []
        for strip in range(1, count + 1):
            route = lanes(polygon, strip, count, lane, altitude)
            if not route:
                return None
            starts.append((route[0][0], route[0][1]))
        return starts

    def on_start(self, ctx: PluginContext) -> None:
        params = ctx.params
        altitude = float(params["altitude"])
        if altitude <= 0:
            raise ValueError(f"{_NAME}: altitude must be > 0 metres, not {altitude:g}")
        speed = params["speed"]
        if speed is not None and speed <= 0:
            raise ValueError(f"{_NAME}: speed must be > 0 m/s, not {speed:g}")
        ctx.require_vehicle()
        polygon = parse_area(str(params["area"]), ctx.areas)
        strip, strips = (ctx.slot, ctx.slots) if ctx.slots > 0 else (1, 1)
        route = lanes(polygon, strip, strips, self.resolve_lane(params), altitude)
        if not route:
            raise ValueError(
                f"{_NAME}: area {params['area']!r} does not reach into strip {strip} of "
                f"{strips}; nothing to search there"
            )
        self._route, self._next, self._done = route, 0, False
        self._command(ctx)

    def step(self, ctx: PluginContext) -> None:
        if self._next >= len(self._route):
            return
        vehicle = ctx.require_vehicle()
        if math.dist(vehicle.position(), self._route[self._next]) > ctx.params["tolerance"]:
            return
        self._next += 1
        if self._next < len(self._route):
            self._command(ctx)
            return
        if not self._done:
            self._done = True
            if ctx.params["event"] is not None:
                ctx.emit(ctx.params["event"], scope="local")
        if ctx.params["loop"] and len(self._route) > 1:
            # The vehicle is at the last waypoint: the reversed route starts there.
            self._route.reverse()
            self._next = 1
            self._command(ctx)
        elif ctx.params["loop"]:
            self._next = 0  # one waypoint: hover over it
        else:
            vehicle.hold()

    def on_activate(self, ctx: PluginContext) -> None:
        if self._next >= len(self._route):
            ctx.require_vehicle().hold()
        else:
            self._command(ctx)

    def snapshot(self) -> dict[str, Any]:
        return {
            "waypoints": [list(point) for point in self._route],
            "next": self._next,
            "done": self._done,
        }

    def restore(self, state: Mapping[str, Any]) -> None:
        route = _read_route(state)
        index, done = state.get("next"), state.get("done")
        if not isinstance(done, bool):
            raise ValueError(f"{_NAME}: a snapshot's 'done' must be true or false, not {done!r}")
        if (
            isinstance(index, bool)
            or not isinstance(index, int)
            or not 0 <= index <= len(route)
            or (index == len(route) and not done)
        ):
            raise ValueError(
                f"{_NAME}: a snapshot's 'next' must be a waypoint index 0..{len(route) - 1} "
                f"(or {len(route)} once done), not {index!r}"
            )
        self._route, self._next, self._done = route, index, done

    def _command(self, ctx: PluginContext) -> None:
        x, y, z = self._route[self._next]
        speed = ctx.params["speed"]
        ctx.require_vehicle().goto(x, y, z, speed=None if speed is None else float(speed))
