"""The area-search plugin: strip and lane geometry, the sweep against the test vehicle and
camera, and the conformance kit."""

from __future__ import annotations

import itertools
import math
from importlib.metadata import entry_points

import pytest

from actorswarm.plugins.search import (
    LANE_PER_ALTITUDE,
    AreaSearch,
    lanes,
    parse_area,
    strip_bounds,
)
from actorswarm.runtime.plugin import ParamError
from actorswarm.testing import FakeCamera, FakeVehicle, check_plugin, make_context, run_plugin

Polygon = list[tuple[float, float]]

RECT: Polygon = [(0.0, 0.0), (100.0, 0.0), (100.0, 60.0), (0.0, 60.0)]
#: A pentagon with slanted edges: lanes must reach past a vertical line's span to cover it.
PENTAGON: Polygon = [(0.0, 0.0), (90.0, -10.0), (120.0, 50.0), (60.0, 95.0), (-5.0, 40.0)]


def inside(polygon: Polygon, x: float, y: float) -> bool:
    """Even-odd rule."""
    hit = False
    n = len(polygon)
    for i in range(n):
        (ax, ay), (bx, by) = polygon[i], polygon[(i + 1) % n]
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            hit = not hit
    return hit


XY = tuple[float, float]


def segment_distance(p: XY, a: XY, b: XY) -> float:
    (px, py), (ax, ay), (bx, by) = p, a, b
    dx, dy = bx - ax, by - ay
    length = dx * dx + dy * dy
    f = 0.0 if length == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / length))
    return math.hypot(px - (ax + f * dx), py - (ay + f * dy))


def lane_segments(route: list[tuple[float, float, float]]) -> list[tuple[tuple[float, float], ...]]:
    """The route's lanes: consecutive waypoints at the same x."""
    out = []
    for a, b in itertools.pairwise(route):
        if a[0] == b[0]:
            out.append(((a[0], a[1]), (b[0], b[1])))
    return out


# --- geometry ------------------------------------------------------------------------------------


@pytest.mark.parametrize("polygon", [RECT, PENTAGON])
@pytest.mark.parametrize("strips", [1, 2, 3, 7])
def test_strips_are_disjoint_and_cover_the_bounding_box(polygon: Polygon, strips: int) -> None:
    xs = [x for x, _ in polygon]
    bounds = [strip_bounds(polygon, k, strips) for k in range(1, strips + 1)]
    assert bounds[0][0] == min(xs) and bounds[-1][1] == max(xs)
    for (_, east), (west, _) in itertools.pairwise(bounds):
        assert east == pytest.approx(west)  # touching, not overlapping
    for west, east in bounds:
        assert east > west
        assert east - west == pytest.approx((max(xs) - min(xs)) / strips)


@pytest.mark.parametrize("polygon", [RECT, PENTAGON])
@pytest.mark.parametrize(("strips", "lane"), [(1, 15.0), (2, 32.0), (3, 7.5), (4, 100.0)])
def test_lanes_cover_every_point_of_their_strip(polygon: Polygon, strips: int, lane: float) -> None:
    xs, ys = [x for x, _ in polygon], [y for _, y in polygon]
    routes = [lanes(polygon, k, strips, lane, 25.0) for k in range(1, strips + 1)]
    for k, route in enumerate(routes, start=1):
        west, east = strip_bounds(polygon, k, strips)
        assert route, f"strip {k} has no lane"
        assert all(z == 25.0 for _, _, z in route)
        assert all(west <= x <= east for x, _, _ in route), "a lane outside its strip"
        columns = sorted({x for x, _, _ in route})
        gaps = [b - a for a, b in itertools.pairwise(columns)]
        assert all(g <= lane + 1e-9 for g in gaps)
        assert columns[0] - west <= lane / 2 + 1e-9 and east - columns[-1] <= lane / 2 + 1e-9
    # Sample the area: every point is within lane / 2 of a lane of the strip it lies in.
    samples = 60
    for i in range(samples + 1):
        for j in range(samples + 1):
            x = min(xs) + (max(xs) - min(xs)) * i / samples
            y = min(ys) + (max(ys) - min(ys)) * j / samples
            if not inside(polygon, x, y):
                continue
            owners = [
                k
                for k in range(1, strips + 1)
                if strip_bounds(polygon, k, strips)[0] <= x <= strip_bounds(polygon, k, strips)[1]
            ]
            best = min(
                segment_distance((x, y), a, b)
                for k in owners
                for a, b in lane_segments(routes[k - 1])
            )
            assert best <= lane / 2 + 1e-9, f"({x:.1f}, {y:.1f}) is {best:.2f} m from a lane"


def test_lanes_are_a_boustrophedon() -> None:
    route = lanes(RECT, 1, 1, 20.0, 10.0)
    assert route == [
        (10.0, 0.0, 10.0),
        (10.0, 60.0, 10.0),
        (30.0, 60.0, 10.0),
        (30.0, 0.0, 10.0),
        (50.0, 0.0, 10.0),
        (50.0, 60.0, 10.0),
        (70.0, 60.0, 10.0),
        (70.0, 0.0, 10.0),
        (90.0, 0.0, 10.0),
        (90.0, 60.0, 10.0),
    ]
    assert lanes(RECT, 2, 2, 100.0, 5.0) == [(75.0, 0.0, 5.0), (75.0, 60.0, 5.0)]


@pytest.mark.parametrize(
    ("strip", "strips", "lane", "message"),
    [(0, 2, 10.0, "strip"), (3, 2, 10.0, "strip"), (1, 0, 10.0, "strips"), (1, 1, 0.0, "lane")],
)
def test_lanes_refuse_bad_arguments(strip: int, strips: int, lane: float, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        lanes(RECT, strip, strips, lane, 20.0)


def test_a_polygon_without_width_is_refused() -> None:
    with pytest.raises(ValueError, match="no width"):
        strip_bounds([(5.0, 0.0), (5.0, 10.0), (5.0, 20.0)], 1, 1)


def test_parse_area_reads_rectangles_and_names() -> None:
    areas = {"search": [(0.0, 0.0), (10.0, 0.0), (5.0, 8.0)]}
    assert parse_area(" 1 2 3 4.5 ", areas) == [(1.0, 2.0), (3.0, 2.0), (3.0, 4.5), (1.0, 4.5)]
    assert parse_area("search", areas) == [(0.0, 0.0), (10.0, 0.0), (5.0, 8.0)]
    with pytest.raises(ValueError, match=r'no area \'serch\' \(did you mean "search"\?\); the '):
        parse_area("serch", areas)
    with pytest.raises(ValueError, match="there are no areas"):
        parse_area("search", {})
    with pytest.raises(ValueError, match="at least 3 vertices"):
        parse_area("line", {"line": [(0.0, 0.0), (1.0, 1.0)]})


@pytest.mark.parametrize("text", ["1 2 3", "0 0 10 10 5", "10 0 0 10", "0 5 10 5"])
def test_a_bad_rectangle_is_refused_with_the_params(text: str) -> None:
    with pytest.raises(ParamError, match="area"):
        make_context(AreaSearch, params={"area": text})


# --- the plugin ----------------------------------------------------------------------------------


def test_entry_point_and_declarations() -> None:
    found = {ep.name: ep.load() for ep in entry_points(group="actorswarm.plugins")}
    assert found["search.area"] is AreaSearch
    assert AreaSearch.bus == "act_bus"
    assert AreaSearch.needs_vehicle is True
    assert AreaSearch.resources == frozenset({"autopilot"})
    assert AreaSearch.params["area"].required
    assert all(param.doc for param in AreaSearch.params.values())


@pytest.mark.parametrize(
    "params",
    [
        {"area": "0 0 100 50"},
        {"area": "0 0 10 10", "loop": "false", "event": "swept", "tolerance": "1"},
        {"area": "-20 -20 20 20", "lane": "5", "speed": "3", "altitude": "8"},
    ],
)
def test_conformance(params: dict[str, str]) -> None:
    check_plugin(AreaSearch, params=params, steps=200)


def test_the_searcher_flies_its_route_and_emits_once_swept() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 10.0), cruise_speed=10.0)
    params = {"area": "0 0 40 30", "lane": "20", "altitude": "10", "event": "swept"}
    ctx = make_context(AreaSearch, params=params, vehicle=vehicle)
    plugin = AreaSearch()
    route = lanes([(0.0, 0.0), (40.0, 0.0), (40.0, 30.0), (0.0, 30.0)], 1, 1, 20.0, 10.0)
    assert run_plugin(plugin, ctx, steps=0) == []
    assert plugin.route == tuple(route)
    assert vehicle.commands == [("goto", *route[0], None)]
    events = []
    for _ in range(200):  # 90 m at 10 m/s, less the 3 m tolerance at each waypoint
        events += run_plugin(plugin, ctx, steps=1)
        if events:
            break
    assert [e.event for e in events] == ["swept"]
    assert 7.0 < ctx.now < 9.5
    assert events[0].scope == "local"
    goals = [c[1:4] for c in vehicle.commands if c[0] == "goto"]
    assert goals[: len(route)] == route  # every waypoint in order
    assert plugin.done
    # Looping: the route again, backwards, and no second event.
    assert plugin.route == tuple(reversed(route))
    assert goals[len(route)] == route[-2]
    assert run_plugin(plugin, ctx, steps=300) == []
    assert len([c for c in vehicle.commands if c[0] == "goto"]) > 2 * len(route)


def test_without_loop_it_holds_at_the_end() -> None:
    vehicle = FakeVehicle(position=(5.0, 0.0, 10.0), cruise_speed=10.0)
    params = {"area": "0 0 10 20", "altitude": "10", "loop": "false", "event": "swept"}
    ctx = make_context(AreaSearch, params=params, vehicle=vehicle)
    plugin = AreaSearch()
    events = run_plugin(plugin, ctx, steps=100)
    assert [e.event for e in events] == ["swept"]
    assert vehicle.commands[-1] == ("hold",)
    assert plugin.snapshot() == {
        "waypoints": [[5.0, 0.0, 10.0], [5.0, 20.0, 10.0]],
        "next": 2,
        "done": True,
    }
    count = len(vehicle.commands)
    assert run_plugin(plugin, ctx, steps=20) == []
    assert len(vehicle.commands) == count


def test_the_members_split_the_area_by_slot() -> None:
    starts = []
    for slot in (1, 2, 3):
        vehicle = FakeVehicle()
        ctx = make_context(
            AreaSearch,
            params={"area": "0 0 90 40", "lane": "30"},
            vehicle=vehicle,
            index=slot,
            size=3,
        )
        plugin = AreaSearch()
        run_plugin(plugin, ctx, steps=0)
        assert {x for x, _, _ in plugin.route} == {15.0 + 30.0 * (slot - 1)}
        starts.append(vehicle.commands[0])
    assert len(set(starts)) == 3
    # Not switched in by a group: the whole area.
    whole = AreaSearch()
    params = {"area": "0 0 90 40", "lane": "30"}
    ctx = make_context(AreaSearch, params=params, vehicle=FakeVehicle())
    run_plugin(whole, ctx, steps=0)
    assert {x for x, _, _ in whole.route} == {15.0, 45.0, 75.0}


def test_named_area_and_unknown_name() -> None:
    areas = {"field": [(0.0, 0.0), (50.0, 0.0), (50.0, 50.0), (0.0, 50.0)]}
    ctx = make_context(AreaSearch, params={"area": "field"}, vehicle=FakeVehicle(), areas=areas)
    plugin = AreaSearch()
    plugin._drive_start(ctx)
    assert plugin.route[0] == (12.5, 0.0, 20.0)  # lane 1.6 × 20 = 32: two lanes of 25 m
    bad = make_context(AreaSearch, params={"area": "feild"}, vehicle=FakeVehicle(), areas=areas)
    with pytest.raises(ValueError, match=r'did you mean "field".*the areas are field'):
        AreaSearch()._drive_start(bad)


def test_default_lane_is_proportional_to_altitude() -> None:
    assert AreaSearch.resolve_lane({"lane": 0.0, "altitude": 25.0}) == LANE_PER_ALTITUDE * 25.0
    assert AreaSearch.resolve_lane({"lane": 7.0, "altitude": 25.0}) == 7.0


def test_the_default_lanes_let_a_90_degree_camera_see_every_target() -> None:
    """Targets scattered over the area, one searcher with the world's camera: each is seen."""
    vehicle = FakeVehicle(position=(0.0, 0.0, 30.0), cruise_speed=12.0)
    targets = {
        f"t{i}{j}": (10.0 + 27.0 * i, 5.0 + 23.0 * j, 0.0) for i in range(6) for j in range(6)
    }
    camera = FakeCamera(vehicle, targets, field_of_view=90.0)
    params = {"area": "0 0 150 130", "altitude": "30", "loop": "false", "event": "swept"}
    ctx = make_context(AreaSearch, params=params, vehicle=vehicle, camera=camera)
    plugin = AreaSearch()
    seen: set[str] = set()
    events = []
    for _ in range(1500):
        events += run_plugin(plugin, ctx, steps=1, dt=0.2)
        seen.update(d.name for d in camera.detections())
        if events:
            break
    assert [e.event for e in events] == ["swept"]
    assert seen == set(targets)


def test_pause_activate_resends_the_waypoint() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 20.0))
    ctx = make_context(AreaSearch, params={"area": "0 0 100 100"}, vehicle=vehicle)
    plugin = AreaSearch()
    run_plugin(plugin, ctx, steps=5)
    plugin._drive_pause(ctx)
    vehicle.hold()  # another actor took the autopilot
    plugin._drive_activate(ctx)
    assert vehicle.commands[-1] == vehicle.commands[0]


def test_snapshot_restore_carries_on_from_the_same_waypoint() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 20.0), cruise_speed=10.0)
    params = {"area": "0 0 64 50", "event": "swept", "loop": "false"}
    ctx = make_context(AreaSearch, params=params, vehicle=vehicle)
    first = AreaSearch()
    run_plugin(first, ctx, steps=80)  # past the first waypoint
    state = first._drive_snapshot()
    assert state["next"] >= 1 and state["done"] is False
    first._drive_stop(ctx)

    other = FakeVehicle(position=vehicle.position(), cruise_speed=10.0)
    later = make_context(
        AreaSearch, params={**params, "area": "500 500 600 600"}, vehicle=other, index=2, size=5
    )
    second = AreaSearch()
    second._drive_restore(state)
    assert second._drive_snapshot() == state
    second._drive_activate(later)
    assert other.commands[0][1:4] == tuple(state["waypoints"][state["next"]])
    events = run_plugin(second, later, steps=300)
    assert [e.event for e in events] == ["swept"]
    assert math.dist(other.position(), tuple(state["waypoints"][-1])) <= 3.0


@pytest.mark.parametrize(
    "state",
    [
        {},
        {"waypoints": [], "next": 0, "done": False},
        {"waypoints": [[0, 0]], "next": 0, "done": False},
        {"waypoints": [[0, 0, "up"]], "next": 0, "done": False},
        {"waypoints": [[0, 0, 1]], "next": 2, "done": True},
        {"waypoints": [[0, 0, 1]], "next": 1, "done": False},
        {"waypoints": [[0, 0, 1]], "next": True, "done": False},
        {"waypoints": [[0, 0, 1]], "next": 0, "done": "no"},
    ],
)
def test_restore_refuses_a_bad_snapshot(state: dict[str, object]) -> None:
    with pytest.raises(ValueError, match=r"search\.area: a snapshot's"):
        AreaSearch()._drive_restore(state)


def test_group_points_are_where_each_strip_s_sweep_begins() -> None:
    params = AreaSearch.bind_params({"area": "search", "altitude": "20"})
    square = [(0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0)]
    points = AreaSearch.group_points(params, 4, 0.0, {"search": square})
    assert points is not None and len(points) == 4
    for strip, (x, y) in enumerate(points, start=1):
        first = lanes(square, strip, 4, AreaSearch.resolve_lane(params), 20.0)[0]
        assert (x, y) == (first[0], first[1])
    with pytest.raises(ValueError, match="no area 'search'"):
        AreaSearch.group_points(params, 4, 0.0, {})
