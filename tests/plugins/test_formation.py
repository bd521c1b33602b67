"""The formation plugins: slot geometry, the virtual leader, the plugin against the test
vehicle and the conformance kit, and ten quadrotors forming up in the world's physics."""

from __future__ import annotations

import itertools
import math
from importlib.metadata import entry_points

import numpy as np
import pytest

from actorswarm.plugins.formation import (
    SHAPES,
    Arrow,
    Circle,
    Formation,
    Grid,
    Herringbone,
    Line,
    SixArrows,
    TwoArrows,
    VirtualLeader,
    parse_route,
    slots,
    to_world,
)
from actorswarm.runtime.plugin import ParamError
from actorswarm.testing import FakeVehicle, check_plugin, make_context, run_plugin
from actorswarm.world.config import load_world
from actorswarm.world.world import World

CLASSES: dict[str, type[Formation]] = {
    "arrow": Arrow,
    "two_arrows": TwoArrows,
    "line": Line,
    "six_arrows": SixArrows,
    "herringbone": Herringbone,
    "circle": Circle,
    "grid": Grid,
}


# --- geometry ------------------------------------------------------------------------------------


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("spacing", [1.0, 20.0])
def test_slots_are_apart_and_start_at_the_leader(shape: str, spacing: float) -> None:
    for n in range(1, 41):
        offsets = slots(shape, n, spacing)
        assert offsets.shape == (n, 2)
        assert np.isfinite(offsets).all()
        assert offsets[0].tolist() == [0.0, 0.0]
        if n > 1:
            gaps = np.linalg.norm(offsets[:, None, :] - offsets[None, :, :], axis=2)
            np.fill_diagonal(gaps, np.inf)
            assert gaps.min() >= spacing, (shape, n, float(gaps.min()))


def test_arrow_opens_backwards_symmetrically() -> None:
    offsets = slots("arrow", 5, 10.0)
    assert (offsets[1:, 0] < 0).all()
    assert offsets[1, 1] > 0 > offsets[2, 1]
    assert offsets[1].tolist() == pytest.approx([offsets[2, 0], -offsets[2, 1]])
    assert math.hypot(*offsets[1]) == pytest.approx(10.0)
    assert math.dist(offsets[1], offsets[3]) == pytest.approx(10.0)


def test_line_is_abreast_and_grid_is_square() -> None:
    line = slots("line", 5, 10.0)
    assert line[:, 0].tolist() == [0.0] * 5
    assert sorted(line[:, 1].tolist()) == [-20.0, -10.0, 0.0, 10.0, 20.0]
    grid = slots("grid", 9, 10.0)
    assert sorted(set(grid[:, 0].tolist())) == [-20.0, -10.0, 0.0]
    assert sorted(set(grid[:, 1].tolist())) == [-10.0, 0.0, 10.0]


def test_composite_shapes_split_the_slots_evenly() -> None:
    two = slots("two_arrows", 10, 10.0)
    assert (two[:5, 1] > two[5:, 1].max()).all()  # the leader's arrow on the left
    assert two[5].tolist() == pytest.approx([0.0, two[5, 1]])  # the other tip abreast
    six = slots("six_arrows", 30, 10.0)
    tips = six[::5]
    assert tips[0].tolist() == [0.0, 0.0]
    assert len({tuple(t) for t in tips.round(6).tolist()}) == 6


def test_circle_rings_the_leader() -> None:
    offsets = slots("circle", 13, 10.0)
    radii = np.linalg.norm(offsets[1:], axis=1)
    assert radii == pytest.approx(np.full(12, radii[0]))
    assert offsets[1].tolist() == pytest.approx([radii[0], 0.0])


def test_herringbone_has_a_spine() -> None:
    offsets = slots("herringbone", 15, 10.0)
    spine = offsets[::5]
    assert spine[:, 1].tolist() == [0.0, 0.0, 0.0]
    assert (np.diff(spine[:, 0]) < 0).all()


@pytest.mark.parametrize(
    ("shape", "n", "spacing"),
    [("star", 3, 1.0), ("arrow", 0, 1.0), ("arrow", 3, 0.0), ("arrow", 3, math.nan)],
)
def test_slots_refuse_bad_arguments(shape: str, n: int, spacing: float) -> None:
    with pytest.raises(ValueError):
        slots(shape, n, spacing)


def test_to_world_rotates_then_translates() -> None:
    offsets = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 5.0]])
    north = to_world(offsets, (100.0, 50.0), math.pi / 2)
    assert north == pytest.approx(np.array([[100.0, 50.0], [100.0, 60.0], [95.0, 50.0]]))
    east = to_world(offsets, (1.0, 2.0), 0.0)
    assert east == pytest.approx(np.array([[1.0, 2.0], [11.0, 2.0], [1.0, 7.0]]))
    one = to_world(np.array([10.0, 0.0]), (0.0, 0.0), math.pi)
    assert one.tolist() == pytest.approx([-10.0, 0.0])


# --- the virtual leader --------------------------------------------------------------------------


def test_leader_flies_the_route_and_stops() -> None:
    leader = VirtualLeader([(0, 0, 10), (100, 0, 10), (100, 50, 10)], speed=10, start_time=5)
    assert leader.length == pytest.approx(150.0)
    assert leader.position(0) == (0.0, 0.0, 10.0)
    assert leader.position(10) == pytest.approx((50.0, 0.0, 10.0))
    assert leader.heading(10) == pytest.approx(0.0)
    assert leader.position(17) == pytest.approx((100.0, 20.0, 10.0))
    assert leader.heading(17) == pytest.approx(math.pi / 2)
    assert leader.position(1000) == pytest.approx((100.0, 50.0, 10.0))
    assert leader.heading(1000) == pytest.approx(math.pi / 2)
    assert leader.moving(10) and not leader.moving(1000) and not leader.moving(1)


def test_leader_loops() -> None:
    leader = VirtualLeader([(0, 0, 0), (30, 0, 0), (30, 40, 0)], speed=10, loop=True)
    assert leader.length == pytest.approx(120.0)  # back to the start: 30 + 40 + 50
    assert leader.position(12) == pytest.approx(leader.position(0))
    assert leader.position(3 + 12 * 5) == pytest.approx((30.0, 0.0, 0.0))
    assert leader.heading(9) == pytest.approx(math.atan2(-40, -30))
    assert leader.moving(1e6)


def test_leader_of_one_point_and_repeated_points() -> None:
    still = VirtualLeader([(5, 6, 7), (5, 6, 7)], speed=3)
    assert still.route == ((5.0, 6.0, 7.0),)
    assert still.position(100) == (5.0, 6.0, 7.0)
    assert still.heading(100) == 0.0
    assert not still.moving(1)


@pytest.mark.parametrize(
    ("route", "speed"),
    [([], 1.0), ([(0, 0)], 1.0), ([(0, 0, math.inf)], 1.0), ([(0, 0, 0)], 0.0)],
)
def test_leader_refuses_bad_arguments(route: list[tuple[float, ...]], speed: float) -> None:
    with pytest.raises(ValueError):
        VirtualLeader(route, speed)


def test_parse_route() -> None:
    assert parse_route("0 0; 10 -5.5;1e2 3;", 30) == [
        (0.0, 0.0, 30.0),
        (10.0, -5.5, 30.0),
        (100.0, 3.0, 30.0),
    ]
    for bad in ("", "1", "1 2 3", "a b", "1 2;; 3 4", "1e999 0"):
        with pytest.raises(ValueError, match="route"):
            parse_route(bad, 30)


# --- the plugin ----------------------------------------------------------------------------------


def test_entry_points_name_the_shapes() -> None:
    found = {ep.name: ep.load() for ep in entry_points(group="actorswarm.plugins")}
    for shape, cls in CLASSES.items():
        assert found[f"formation.{shape}"] is cls
        assert cls.shape == shape
        assert cls.entry_name() == f"formation.{shape}"
        assert cls.bus == "act_bus"
        assert cls.needs_vehicle is True
        assert cls.resources == frozenset({"autopilot"})
        assert all(param.doc for param in cls.params.values())


@pytest.mark.parametrize(
    ("cls", "params"),
    [
        (Arrow, {}),
        (Herringbone, {"route": "0 0; 50 0; 50 50", "speed": "4", "size": "12"}),
        (Circle, {"route": "0 0; 10 0", "loop": "true", "altitude_step": "2"}),
    ],
)
def test_conformance(cls: type[Formation], params: dict[str, str]) -> None:
    check_plugin(cls, params=params)


def test_route_param_is_checked_with_the_params() -> None:
    with pytest.raises(ParamError, match="route"):
        make_context(Arrow, params={"route": "1 2; three 4"})


def test_member_flies_to_its_slot_and_follows_the_leader() -> None:
    vehicle = FakeVehicle(position=(0.0, -20.0, 30.0), cruise_speed=20.0)
    params = {"route": "0 0; 100 0", "speed": "5", "spacing": "10", "size": "5"}
    ctx = make_context(Arrow, params=params, vehicle=vehicle, index=2)
    plugin = Arrow()
    run_plugin(plugin, ctx, steps=1)
    expected = to_world(slots("arrow", 5, 10.0)[1], (0.0, 0.0), 0.0)
    first = vehicle.commands[0]
    assert first[0] == "goto"
    # While the leader moves the member aims lookahead (4 s) × speed (5 m/s) past its slot.
    assert first[1:3] == pytest.approx(tuple((expected + np.array([20.0, 0.0])).tolist()))
    assert first[3] == 30.0
    # The leader's speed plus what closes the along-track gap in 5 s: the member starts
    # 7.7 m ahead of its slot (x 0 against -7.66), so it asks for less than the leader.
    assert first[4] == pytest.approx(5.0 + float(expected[0]) / 5.0)
    run_plugin(plugin, ctx, steps=400)  # 40 s: the leader went 100 m and stopped at 20 s
    point = plugin.slot_point(ctx.now)
    assert point[:2] == pytest.approx(tuple((expected + np.array([100.0, 0.0])).tolist()))
    assert math.dist(vehicle.position(), point) < 0.5
    # Far fewer commands than steps: a target that moved less than a metre is not re-sent.
    count = len(vehicle.commands)
    assert 10 < count < 200
    run_plugin(plugin, ctx, steps=50)
    assert len(vehicle.commands) == count  # the leader is stopped: nothing to send


def test_index_zero_is_slot_one_and_altitude_step_layers() -> None:
    vehicle = FakeVehicle()
    params = {"route": "40 50", "altitude": "20", "altitude_step": "3"}
    run_plugin(Line(), make_context(Line, params=params, vehicle=vehicle, index=0), steps=1)
    assert vehicle.commands[0][1:4] == (40.0, 50.0, 20.0)
    other = FakeVehicle()
    run_plugin(Line(), make_context(Line, params=params, vehicle=other, index=4), steps=1)
    assert other.commands[0][3] == 29.0


def test_index_beyond_size_is_refused() -> None:
    ctx = make_context(Grid, params={"size": "4"}, vehicle=FakeVehicle(), index=5)
    with pytest.raises(ValueError, match="slot 5 is beyond size 4"):
        Grid()._drive_start(ctx)


def test_restore_keeps_the_leader_start() -> None:
    params = {"route": "0 0; 1000 0", "speed": "10"}
    ctx = make_context(Arrow, params=params, vehicle=FakeVehicle(), now=100.0, index=1)
    plugin = Arrow()
    plugin._drive_start(ctx)
    saved = plugin._drive_snapshot()
    assert saved == {"start": 100.0, "after_task": None, "arrived": False}
    vehicle = FakeVehicle()
    later = make_context(Arrow, params=params, vehicle=vehicle, now=130.0, index=1)
    fresh = Arrow()
    fresh._drive_restore(saved)
    fresh._drive_activate(later)
    # The leader is 300 m along; the member aims 4 s × 10 m/s ahead of its slot.
    assert vehicle.commands[0][1:4] == pytest.approx((340.0, 0.0, 30.0))
    with pytest.raises(ValueError, match="start"):
        Arrow()._drive_restore({"start": "soon"})
    with pytest.raises(ValueError, match="after_task"):
        Arrow()._drive_restore({"start": 1.0, "after_task": "later"})


def test_a_platform_restored_on_a_new_clock_keeps_the_leader_where_the_swarm_has_it() -> None:
    """A daemon restarted after a reboot resumes its formation on a new monotonic clock:
    the leader's start is put back by its time after the task's start, which the platform
    knows on the new clock, not by the old clock's reading."""
    params = {"route": "0 0; 1000 0", "speed": "10"}
    ctx = make_context(
        Arrow, params=params, vehicle=FakeVehicle(), now=100.0, index=1, task_start=40.0
    )
    plugin = Arrow()
    plugin._drive_start(ctx)
    saved = plugin._drive_snapshot()
    assert saved == {"start": 100.0, "after_task": 60.0, "arrived": False}
    vehicle = FakeVehicle()
    # The new clock reads 5000 - 4000 = 1000 s less: the task began at -3960 on it, and at
    # 1030 on the old clock's 130 the leader is 300 m along, as it would be unrebooted.
    later = make_context(
        Arrow, params=params, vehicle=vehicle, now=130.0 - 4000.0, index=1, task_start=-3960.0
    )
    fresh = Arrow()
    fresh._drive_restore(saved)
    fresh._drive_activate(later)
    assert vehicle.commands[0][1:4] == pytest.approx((340.0, 0.0, 30.0))


# --- ten quadrotors in the world's physics -------------------------------------------------------


@pytest.mark.parametrize("shape", SHAPES)
def test_ten_quadrotors_form_up(shape: str) -> None:
    world = World(load_world(None), platforms=range(1, 11))
    cls = CLASSES[shape]
    params = {
        "spacing": "15",
        "speed": "5",
        "altitude": "20",
        "altitude_step": "6",
        "size": "10",
        "route": "15 60; 15 160",
    }
    contexts = {
        p: make_context(cls, params=params, vehicle=world.vehicle(p), platform=p, index=p)
        for p in world.platforms
    }
    members = {p: cls() for p in world.platforms}
    for p, member in members.items():
        member._drive_start(contexts[p])  # on the ground: the goto takes off on the way
    closest = math.inf
    dt = 0.1
    for k in range(1, 601):  # 60 s
        t = k * dt
        world.step_to(t)
        for p, member in members.items():
            contexts[p].now = t
            member._drive_step(contexts[p])
        positions = world.positions()
        if all(z > 1.0 for _, _, z in positions.values()):
            for a, b in itertools.combinations(positions.values(), 2):
                closest = min(closest, math.dist(a, b))
    assert closest >= 5.0, f"{shape}: two vehicles came within {closest:.2f} m"
    positions = world.positions()
    for p, member in members.items():
        error = math.dist(positions[p], member.slot_point(60.0))
        assert error < 5.0, f"{shape}: platform {p} is {error:.1f} m from its slot"
    # And the slots are the shape's, laid along the route's heading (north).
    expected = to_world(slots(shape, 10, 15.0), (15.0, 160.0), math.pi / 2)
    for p, member in members.items():
        assert member.slot_point(60.0)[:2] == pytest.approx(tuple(expected[p - 1].tolist()))


def test_a_shared_departure_puts_every_formation_on_one_leader() -> None:
    """Two formation actors with the same route and depart follow one leader: the second,
    started later, picks the leader up where the first one's is."""
    params = {"route": "0 0; 1000 0", "speed": "10", "depart": "5", "lookahead": "0"}
    first = make_context(Arrow, params=params, vehicle=FakeVehicle(), now=5.0, slot=1, slots=3)
    arrow = Arrow()
    arrow._drive_start(first)
    later = make_context(Line, params=params, vehicle=FakeVehicle(), now=25.0, slot=1, slots=3)
    line = Line()
    line._drive_start(later)
    assert line.slot_point(25.0) == pytest.approx(arrow.slot_point(25.0)) == (200.0, 0.0, 30.0)


def test_depart_counts_from_the_task_s_start_on_each_platform_s_clock() -> None:
    """Two platforms whose clocks differ by 1000 s (a daemon's is monotonic) follow one
    leader: ``depart`` counts from the task's start, which each knows on its own clock — and
    the master's slot assignment (group_points) puts the slots at the same places."""
    params = {"route": "0 0; 1000 0", "speed": "10", "depart": "5", "lookahead": "0"}
    slot_points = []
    for offset in (0.0, 1000.0):
        ctx = make_context(
            Arrow,
            params=params,
            vehicle=FakeVehicle(),
            now=offset + 20.0,
            slot=1,
            slots=3,
            task_start=offset + 10.0,
        )
        arrow = Arrow()
        arrow._drive_start(ctx)
        # The leader left 15 s after the task began: at 25 s of the task it is 100 m out.
        slot_points.append(arrow.slot_point(offset + 25.0))
        bound = Arrow.bind_params(params)
        points = Arrow.group_points(bound, 3, offset + 25.0, {}, task_start=offset + 10.0)
        assert points is not None and points[0] == pytest.approx(slot_points[-1][:2])
    assert slot_points[0] == pytest.approx(slot_points[1]) == (100.0, 0.0, 30.0)


def test_offset_moves_the_formation_s_own_leader() -> None:
    params = {"route": "0 0; 1000 0", "speed": "10", "offset": "-250 40"}
    ctx = make_context(Line, params=params, vehicle=FakeVehicle(), now=0.0, slot=1, slots=5)
    line = Line()
    line._drive_start(ctx)
    assert line.slot_point(10.0) == pytest.approx((100.0 - 250.0, 40.0, 30.0))


def test_size_zero_takes_the_branch_s_number_of_slots() -> None:
    """With size 0 the shape is the firing's branch: slot 3 of 3 of an arrow is the second
    rank's right-hand slot, wherever the member's index in the whole group was."""
    params = {"route": "0 0", "spacing": "10"}
    ctx = make_context(
        Arrow, params=params, vehicle=FakeVehicle(), index=9, size=12, slot=3, slots=3
    )
    arrow = Arrow()
    arrow._drive_start(ctx)
    expected = slots("arrow", 3, 10.0)[2]
    assert arrow.slot_point(0.0)[:2] == pytest.approx(tuple(expected.tolist()))


def test_switched_back_in_with_a_new_slot_re_forms_on_the_same_leader() -> None:
    params = {"route": "0 0; 1000 0", "speed": "10", "spacing": "10", "lookahead": "0"}
    vehicle = FakeVehicle()
    ctx = make_context(Arrow, params=params, vehicle=vehicle, now=0.0, slot=1, slots=3)
    arrow = Arrow()
    arrow._drive_start(ctx)
    arrow._drive_pause(ctx)
    back = make_context(Arrow, params=params, vehicle=vehicle, now=20.0, slot=3, slots=3)
    arrow._drive_activate(back)
    leader = (200.0, 0.0)
    expected = to_world(slots("arrow", 3, 10.0)[2], leader, 0.0)
    assert arrow.slot_point(20.0)[:2] == pytest.approx(tuple(expected.tolist()))
    assert arrow._drive_snapshot()["start"] == 0.0, "the leader did not start again"


def test_arrival_event_fires_once_when_the_leader_stopped_and_the_member_is_on_its_slot() -> None:
    params = {
        "route": "0 0; 50 0",
        "speed": "10",
        "lookahead": "0",
        "event": "arriving_event",
        "tolerance": "2",
    }
    vehicle = FakeVehicle(position=(0.0, 0.0, 30.0), cruise_speed=20.0)
    ctx = make_context(Arrow, params=params, vehicle=vehicle, slot=1, slots=1)
    arrow = Arrow()
    early = run_plugin(arrow, ctx, steps=40)  # 4 s: the leader is still on its way
    assert early == []
    later = run_plugin(arrow, ctx, steps=100)
    assert [e.event for e in later] == ["arriving_event"]
    assert math.dist(vehicle.position(), (50.0, 0.0, 30.0)) <= 2.0
    assert run_plugin(arrow, ctx, steps=20) == [], "once per start"
    assert arrow._drive_snapshot()["arrived"] is True


def test_a_looping_route_never_arrives() -> None:
    params = {"route": "0 0; 20 0", "loop": "true", "speed": "10", "event": "arriving_event"}
    ctx = make_context(Arrow, params=params, vehicle=FakeVehicle(cruise_speed=20.0))
    assert run_plugin(Arrow(), ctx, steps=200) == []


# --- a change of shape that crosses, deconflicted by the transit layers -------------------------


def _swap(transit_step: str) -> float:
    """Two quadrotors hovering 360 m apart on a north-south line, each sent to the slot on
    the other's side (a crossing no assignment can avoid: it is given): the least distance
    between them on the way."""
    from actorswarm.world.config import loads_world
    from actorswarm.world.separation import SeparationMonitor

    world = World(
        loads_world(
            "[[vehicles]]\nplatform = 1\nhome = [0.0, 200.0]\n"
            "[[vehicles]]\nplatform = 2\nhome = [0.0, -160.0]\n"
        ),
        platforms=(1, 2),
    )
    for p in (1, 2):
        world.vehicle(p).takeoff(30.0)
    world.step_to(15.0)  # both hover at 30 m
    params = {"spacing": "40", "altitude": "30", "route": "0 0", "size": "2"}
    params["transit_step"] = transit_step
    contexts = {
        p: make_context(Line, params=params, vehicle=world.vehicle(p), now=15.0, slot=p, slots=2)
        for p in (1, 2)
    }
    members = {p: Line() for p in (1, 2)}
    for p, member in members.items():
        member._drive_start(contexts[p])
    monitor = SeparationMonitor([1, 2], [3.0, 3.0])
    for k in range(1, 601):  # 60 s
        t = 15.0 + k * 0.1
        world.step_to(t)
        for p, member in members.items():
            contexts[p].now = t
            member._drive_step(contexts[p])
        monitor.observe(t, world.fleet.positions, np.ones(2, dtype=bool))
    for p, member in members.items():  # arrived, back at the formation's altitude
        assert math.dist(world.vehicle(p).position(), member.slot_point(75.0)) < 2.0
    closest = monitor.result().closest
    assert closest is not None
    return closest.distance


def test_a_crossing_change_of_shape_is_deconflicted_by_the_transit_layers() -> None:
    # Slot 1 (the leader's, at 0 0) for the one in the north, slot 2 (40 m north) for the
    # one in the south: head-on at one altitude, they would pass within a metre.
    assert _swap("0") < 1.0
    # On transit layers 6 m apart (slot 1 at 30 - 3 x 6 m, slot 2 at 30 - 2 x 6 m) they
    # pass one above the other (5.4 m: one is still settling onto its layer), well clear of
    # a quadrotor's 3 m separation.
    assert _swap("6") >= 5.0


def test_transit_layers_zero_gives_every_member_a_layer_of_its_own() -> None:
    """Slots 5 and 9 of ten share the default four layers' first (80 - 2 x 10 m); with
    transit_layers 0 there are ten, and they fly 70 m and 120 m."""

    def transit_altitude(slot: int, layers: str | None) -> float:
        params = {"route": "0 0", "size": "10", "spacing": "40", "altitude": "80"}
        params["transit_step"] = "10"
        if layers is not None:
            params["transit_layers"] = layers
        vehicle = FakeVehicle(position=(800.0, 800.0, 80.0))
        ctx = make_context(Arrow, params=params, vehicle=vehicle, slot=slot, slots=10)
        Arrow()._drive_start(ctx)
        (command,) = vehicle.commands
        return float(command[3])

    assert transit_altitude(5, None) == transit_altitude(9, None) == 60.0
    assert (transit_altitude(5, "0"), transit_altitude(9, "0")) == (70.0, 120.0)


def test_transit_hold_keeps_a_take_off_layer_until_near_the_slot() -> None:
    """With transit_hold, a member that starts 40 m above the formation (a take-off layer)
    flies to its slot at its own altitude, not down to its transit layer (70 m) through
    the others' altitudes; near the slot it takes the slot's 80 m. One that starts at the
    formation's altitude, or less than a step off it, still takes its transit layer."""

    def altitudes(start_z: float, hold: str) -> list[float]:
        """The altitudes the member asks for on its way, in order, each once."""
        params = {"route": "0 0", "size": "10", "spacing": "40", "altitude": "80"}
        params |= {"transit_step": "10", "transit_layers": "0", "transit_hold": hold}
        vehicle = FakeVehicle(position=(300.0, 300.0, start_z), cruise_speed=20.0)
        ctx = make_context(Arrow, params=params, vehicle=vehicle, slot=5, slots=10)
        member = Arrow()
        member._drive_start(ctx)
        for k in range(1, 601):
            vehicle.advance(0.1)
            ctx.now = k * 0.1
            member._drive_step(ctx)
        assert math.dist(vehicle.position(), member.slot_point(ctx.now)) < 1.0
        asked = [float(c[3]) for c in vehicle.commands if c[0] == "goto"]
        return [z for i, z in enumerate(asked) if i == 0 or z != asked[i - 1]]

    assert altitudes(120.0, "true") == [120.0, 80.0]
    assert altitudes(120.0, "false") == [70.0, 80.0]
    assert altitudes(80.0, "true") == [70.0, 80.0]
    assert altitudes(85.0, "true") == [70.0, 80.0]
