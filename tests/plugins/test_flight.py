"""The flight plugins: against the test vehicle, through the conformance kit, and flying a
whole take-off / ingress / return mission in the simulated world's physics."""

from __future__ import annotations

import math
from importlib.metadata import entry_points

import pytest

from actorswarm.engine.runtime import Emitted
from actorswarm.plugins.flight import GoTo, ReturnHome, TakeOff
from actorswarm.runtime.context import PluginContext
from actorswarm.runtime.plugin import Plugin
from actorswarm.testing import FakeVehicle, check_plugin, make_context, run_plugin
from actorswarm.world.config import load_world
from actorswarm.world.world import World


def names(events: list[Emitted]) -> list[str]:
    return [e.event for e in events]


# --- registration and declarations ---------------------------------------------------------------


def test_entry_points_name_the_three_plugins() -> None:
    found = {ep.name: ep.load() for ep in entry_points(group="actorswarm.plugins")}
    assert found["flight.takeoff"] is TakeOff
    assert found["flight.goto"] is GoTo
    assert found["flight.return_home"] is ReturnHome


@pytest.mark.parametrize("cls", [TakeOff, GoTo, ReturnHome])
def test_declarations(cls: type[Plugin]) -> None:
    assert cls.bus == "act_bus"
    assert cls.needs_vehicle is True
    assert cls.resources == frozenset({"autopilot"})
    assert all(param.doc for param in cls.params.values())


@pytest.mark.parametrize(
    ("cls", "params"),
    [
        (TakeOff, {}),
        (TakeOff, {"altitude": "3", "scope": "swarm"}),
        (TakeOff, {"altitude": "3", "layers": "2", "layer_step": "5", "stagger": "1"}),
        (TakeOff, {"altitude": "30", "late_after": "5", "late_below": "12"}),
        (GoTo, {"target": "4 3 2"}),
        (GoTo, {"TargetPoint": "1 1 1", "speed": "2"}),
        (ReturnHome, {}),
        (ReturnHome, {"home": "3 4 0", "altitude": "2"}),
        (ReturnHome, {"home": "1 0 0", "altitude": "1", "land": "false"}),
    ],
)
def test_conformance(cls: type[Plugin], params: dict[str, str]) -> None:
    check_plugin(cls, params=params)


# --- TakeOff -------------------------------------------------------------------------------------


def test_takeoff_emits_once_at_altitude_then_holds() -> None:
    vehicle = FakeVehicle(climb_rate=2.0)
    ctx = make_context(TakeOff, params={"altitude": "10"}, vehicle=vehicle)
    plugin = TakeOff()
    events = run_plugin(plugin, ctx, steps=40, dt=0.1)  # 4 s: 8 m, not there yet
    assert events == []
    assert vehicle.commands == [("takeoff", 10.0)]
    events = run_plugin(plugin, ctx, steps=100, dt=0.1)
    assert names(events) == ["ready_event"]
    assert events[0].scope == "local"
    assert vehicle.commands[-1] == ("hold",)
    assert abs(vehicle.position()[2] - 10.0) <= 1.0


def test_takeoff_already_at_altitude_sends_no_takeoff() -> None:
    vehicle = FakeVehicle(position=(5.0, 5.0, 19.5))
    ctx = make_context(TakeOff, params={"event": "up", "scope": "swarm"}, vehicle=vehicle)
    events = run_plugin(TakeOff(), ctx, steps=3)
    assert [(e.event, e.scope) for e in events] == [("up", "swarm")]
    assert vehicle.commands == [("hold",)]


def test_takeoff_snapshot_restore_mid_climb() -> None:
    vehicle = FakeVehicle()
    ctx = make_context(TakeOff, params={"altitude": "10"}, vehicle=vehicle)
    first = TakeOff()
    assert run_plugin(first, ctx, steps=20) == []
    state = first._drive_snapshot()
    assert state == {"fired": False, "low": False}
    first._drive_stop(ctx)
    vehicle.hold()  # another actor stopped the climb meanwhile

    second = TakeOff()
    second._drive_restore(state)
    second._drive_activate(ctx)
    assert vehicle.commands[-1] == ("takeoff", 10.0)
    events = run_plugin(second, ctx, steps=100)
    assert names(events) == ["ready_event"]


class LateVehicle(FakeVehicle):
    """An autopilot ready only from ``ready_at`` seconds of its own clock: a take-off asked
    earlier waits on the ground (as a real ARM does) and goes then."""

    def __init__(self, ready_at: float, **kwargs: float) -> None:
        super().__init__(**kwargs)
        self.ready_at = ready_at
        self.clock = 0.0

    def advance(self, dt: float) -> None:
        self.clock += dt
        if self.clock >= self.ready_at:
            super().advance(dt)


LATE = {"altitude": "60", "late_after": "10", "late_below": "20"}


def test_takeoff_late_holds_below_the_others() -> None:
    """Ready 30 s after its turn: still on the ground 10 s after it, it is sent to 40 m
    instead, 20 m under the others' circles, climbs only there and its event fires
    there."""
    vehicle = LateVehicle(30.0, climb_rate=4.0)
    ctx = make_context(TakeOff, params=LATE, vehicle=vehicle)
    plugin = TakeOff()
    assert run_plugin(plugin, ctx, steps=95, dt=0.1) == []  # 9.5 s on the ground
    assert vehicle.commands == [("takeoff", 60.0)]
    assert run_plugin(plugin, ctx, steps=195, dt=0.1) == []  # 29 s on the ground
    assert vehicle.commands == [("takeoff", 60.0), ("takeoff", 40.0)]
    events = run_plugin(plugin, ctx, steps=200, dt=0.1)
    assert vehicle.commands[:2] == [("takeoff", 60.0), ("takeoff", 40.0)]
    assert names(events) == ["ready_event"]
    assert abs(vehicle.position()[2] - 40.0) <= 1.0
    assert plugin._drive_snapshot() == {"fired": True, "low": True}


class WanderingLateVehicle(LateVehicle):
    """A late autopilot whose height on its runway wanders, as ArduPlane's does before
    arming (-0.22 to +0.40 m measured in SITL): it reads 0.4 m while still on the ground."""

    def position(self) -> tuple[float, float, float]:
        x, y, z = super().position()
        return (x, y, 0.4) if z == 0.0 else (x, y, z)


def test_takeoff_late_is_not_fooled_by_the_ground_height_wandering() -> None:
    """0.4 m read on the runway is not "off the ground": the aircraft that really leaves
    it 30 s after its turn is late and holds low (with 0.2 m as the threshold it was taken
    as airborne from the start, and climbed through the others to 60 m)."""
    vehicle = WanderingLateVehicle(30.0, climb_rate=4.0)
    ctx = make_context(TakeOff, params=LATE, vehicle=vehicle)
    events = run_plugin(TakeOff(), ctx, steps=500, dt=0.1)
    assert vehicle.commands[:2] == [("takeoff", 60.0), ("takeoff", 40.0)]
    assert names(events) == ["ready_event"]
    assert abs(vehicle.position()[2] - 40.0) <= 1.0


@pytest.mark.parametrize("ready_at", [0.0, 9.5])
def test_takeoff_in_time_climbs_to_its_altitude(ready_at: float) -> None:
    """Off the ground within ``late_after`` of its turn: the take-off as without it."""
    vehicle = LateVehicle(ready_at, climb_rate=4.0)
    events = run_plugin(TakeOff(), make_context(TakeOff, params=LATE, vehicle=vehicle), steps=300)
    assert vehicle.commands[0] == ("takeoff", 60.0)
    assert ("takeoff", 40.0) not in vehicle.commands
    assert names(events) == ["ready_event"]
    assert abs(vehicle.position()[2] - 60.0) <= 1.0


def test_takeoff_late_is_counted_from_its_layers_turn() -> None:
    """Layer 1 of a 20 s stagger is asked at 20 s: off the ground at 25 s is in time."""
    params = {**LATE, "layers": "2", "layer_step": "10", "stagger": "20"}
    vehicle = LateVehicle(25.0, climb_rate=4.0)
    ctx = make_context(TakeOff, params=params, vehicle=vehicle, platform=2)
    events = run_plugin(TakeOff(), ctx, steps=500, dt=0.1)
    assert vehicle.commands[0] == ("takeoff", 70.0)
    assert ("takeoff", 40.0) not in vehicle.commands
    assert names(events) == ["ready_event"]


def test_takeoff_restored_late_climbs_to_the_low_altitude() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 12.0), climb_rate=4.0)
    ctx = make_context(TakeOff, params=LATE, vehicle=vehicle)
    plugin = TakeOff()
    plugin._drive_restore({"fired": False, "low": True})
    plugin._drive_activate(ctx)
    assert vehicle.commands == [("takeoff", 40.0)]
    assert names(run_plugin(plugin, ctx, steps=100)) == ["ready_event"]
    older = TakeOff()  # a backup from before the flag: not late
    older._drive_restore({"fired": False})
    older._drive_activate(ctx)
    assert vehicle.commands[-1] == ("takeoff", 60.0)


def test_takeoff_late_below_must_be_under_the_altitude() -> None:
    ctx = make_context(TakeOff, params={**LATE, "late_below": "60"}, vehicle=FakeVehicle())
    with pytest.raises(ValueError, match=r"late_below \(60 m\) must be under altitude"):
        TakeOff()._drive_start(ctx)


# --- GoTo ----------------------------------------------------------------------------------------


def test_goto_emits_once_within_tolerance_then_holds() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 10.0), cruise_speed=5.0)
    ctx = make_context(GoTo, params={"target": "50 0 10", "speed": "4"}, vehicle=vehicle)
    plugin = GoTo()
    events = run_plugin(plugin, ctx, steps=100, dt=0.1)  # 10 s at 4 m/s: 40 m, not yet
    assert events == []
    assert vehicle.commands == [("goto", 50.0, 0.0, 10.0, 4.0)]
    events = run_plugin(plugin, ctx, steps=100, dt=0.1)
    assert names(events) == ["arriving_event"]
    assert vehicle.commands[-1] == ("hold",)
    assert math.dist(vehicle.position(), (50.0, 0.0, 10.0)) <= 5.0


def test_goto_transition_target_point_wins() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 10.0))
    ctx = make_context(
        GoTo,
        params={"target": "50 0 10"},
        transition_params={"TargetPoint": "0 30 10", "Other": "ignored"},
        vehicle=vehicle,
    )
    events = run_plugin(GoTo(), ctx, steps=200)
    assert names(events) == ["arriving_event"]
    assert vehicle.commands[0] == ("goto", 0.0, 30.0, 10.0, None)
    assert math.dist(vehicle.position(), (0.0, 30.0, 10.0)) <= 5.0


def test_goto_target_point_alone_is_enough() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 10.0))
    ctx = make_context(GoTo, transition_params={"TargetPoint": "10 0 10"}, vehicle=vehicle)
    assert names(run_plugin(GoTo(), ctx, steps=50)) == ["arriving_event"]


def test_goto_without_any_point_refuses_to_start() -> None:
    ctx = make_context(GoTo, vehicle=FakeVehicle())
    with pytest.raises(ValueError, match="no point to fly to"):
        GoTo()._drive_start(ctx)


def test_goto_snapshot_restore_mid_flight_keeps_the_point() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 10.0))
    ctx = make_context(GoTo, transition_params={"TargetPoint": "40 0 10"}, vehicle=vehicle)
    first = GoTo()
    assert run_plugin(first, ctx, steps=30) == []
    state = first._drive_snapshot()
    assert state == {"target": [40.0, 0.0, 10.0], "fired": False}
    first._drive_stop(ctx)
    vehicle.hold()

    # The restoring host has only the script's params: the snapshot keeps the point.
    later = make_context(GoTo, params={"target": "-40 0 10"}, vehicle=vehicle, now=ctx.now)
    second = GoTo()
    second._drive_restore(state)
    second._drive_activate(later)
    assert vehicle.commands[-1] == ("goto", 40.0, 0.0, 10.0, None)
    events = run_plugin(second, later, steps=100)
    assert names(events) == ["arriving_event"]
    assert second._drive_snapshot() == {"target": [40.0, 0.0, 10.0], "fired": True}


def test_goto_restore_refuses_a_bad_snapshot() -> None:
    with pytest.raises(ValueError, match="target"):
        GoTo()._drive_restore({"target": [1, 2], "fired": False})


# --- ReturnHome ----------------------------------------------------------------------------------


def test_takeoff_layers_and_staggers_by_platform() -> None:
    """Platform 3 of three layers, 10 m and 20 s apart: layer 2 waits 40 s, then climbs to
    its own altitude, and its event fires there (not at the first layer's)."""
    params = {
        "altitude": "60",
        "tolerance": "1",
        "layers": "3",
        "layer_step": "10",
        "stagger": "20",
    }
    vehicle = FakeVehicle(climb_rate=4.0)
    ctx = make_context(TakeOff, params=params, vehicle=vehicle, platform=3)
    plugin = TakeOff()
    assert run_plugin(plugin, ctx, steps=390, dt=0.1) == []  # 39 s: still waiting its turn
    assert vehicle.commands == []
    events = run_plugin(plugin, ctx, steps=300, dt=0.1)
    assert vehicle.commands[0] == ("takeoff", 80.0)
    assert names(events) == ["ready_event"]
    assert abs(vehicle.position()[2] - 80.0) <= 1.0
    first = FakeVehicle(climb_rate=4.0)  # platform 4 is on layer 0 again: at once, 60 m
    run_plugin(TakeOff(), make_context(TakeOff, params=params, vehicle=first, platform=4), steps=1)
    assert first.commands == [("takeoff", 60.0)]


def test_return_home_lands_in_turn_waiting_over_home() -> None:
    params = {"home": "0 0 0", "altitude": "10", "layers": "0", "land_stagger": "30"}
    vehicle = FakeVehicle(position=(0.0, 5.0, 10.0), cruise_speed=10.0, climb_rate=3.0)
    ctx = make_context(ReturnHome, params=params, vehicle=vehicle, slot=2, slots=3)
    plugin = ReturnHome()
    plugin._drive_start(ctx)
    assert plugin._drive_snapshot()["land_wait"] == pytest.approx(30.0)  # not home yet
    run_plugin(plugin, ctx, steps=290, dt=0.1)  # over home within 1 s; its turn 30 s on
    assert ("land",) not in vehicle.commands
    snapshot = plugin._drive_snapshot()
    assert 30.0 < snapshot["land_at"] <= 31.0
    events = run_plugin(plugin, ctx, steps=200, dt=0.1)
    assert ("land",) in vehicle.commands and names(events) == ["landed_event"]
    again = ReturnHome()
    again._drive_restore(snapshot)
    assert again._drive_snapshot()["land_at"] == snapshot["land_at"]


def test_return_home_keeps_its_turn_across_a_reboot() -> None:
    """A member waiting over home is restored on a new clock (its robot rebooted): it lands
    when its turn comes in the task's time, not at the old clock's instant (which the new
    clock would reach only after an hour)."""
    params = {"home": "0 0 0", "altitude": "10", "layers": "0", "land_stagger": "30"}
    vehicle = FakeVehicle(position=(0.0, 5.0, 10.0), cruise_speed=10.0, climb_rate=3.0)
    ctx = make_context(
        ReturnHome, params=params, vehicle=vehicle, slot=2, slots=3, now=4000.0, task_start=3900.0
    )
    plugin = ReturnHome()
    run_plugin(plugin, ctx, steps=50, dt=0.1)  # over home within 1 s: its turn 30 s later
    snapshot = plugin._drive_snapshot()
    turn = snapshot["land_after_task"]
    assert 130.0 < turn <= 131.0
    assert snapshot["land_at"] - 3900.0 == pytest.approx(turn)

    rebooted = FakeVehicle(position=(0.0, 0.0, 10.0), cruise_speed=10.0, climb_rate=3.0)
    # The new clock reads 60 s at 110 s of the task.
    later = make_context(
        ReturnHome, params=params, vehicle=rebooted, slot=2, slots=3, now=60.0, task_start=-50.0
    )
    again = ReturnHome()
    again._drive_restore(snapshot)
    assert again._drive_snapshot()["land_after_task"] == turn  # kept until activated
    again._drive_activate(later)
    assert again._drive_snapshot()["land_at"] == pytest.approx(-50.0 + turn)
    run_plugin(again, later, steps=int((turn - 110.0) * 10) - 5, dt=0.1)
    assert ("land",) not in rebooted.commands  # half a second before its turn
    run_plugin(again, later, steps=10, dt=0.1)
    assert ("land",) in rebooted.commands


def test_return_home_without_a_task_clock_keeps_the_saved_instant() -> None:
    """A snapshot from a host with no task clock (or an older backup) restores its turn as
    the time it was, on the same clock."""
    plugin = ReturnHome()
    state = {"home": [0.0, 0.0, 0.0], "phase": "transit", "land_at": 75.0}
    plugin._drive_restore(state)
    plugin._drive_activate(make_context(ReturnHome, vehicle=FakeVehicle(), now=70.0))
    assert plugin._drive_snapshot()["land_at"] == 75.0
    assert "land_after_task" not in plugin._drive_snapshot()
    with pytest.raises(ValueError, match="land_after_task"):
        ReturnHome()._drive_restore({**state, "land_after_task": "soon"})


def test_return_home_counts_its_turn_from_when_it_is_first_over_home() -> None:
    """The way home took longer than one stagger: the member on layer 1 still lands a
    stagger after it came home, not at once (as it would counting from the start)."""
    params = {"home": "0 0 0", "altitude": "10", "layers": "0", "land_stagger": "30"}
    vehicle = FakeVehicle(position=(400.0, 0.0, 10.0), cruise_speed=10.0, climb_rate=3.0)
    ctx = make_context(ReturnHome, params=params, vehicle=vehicle, slot=2, slots=3)
    plugin = ReturnHome()
    run_plugin(plugin, ctx, steps=400, dt=0.1)  # 40 s home: its turn from the start is past
    assert ("land",) not in vehicle.commands
    arrived = plugin._drive_snapshot()["land_at"] - 30.0
    assert 35.0 <= arrived <= 40.0
    run_plugin(plugin, ctx, steps=320, dt=0.1)
    assert ("land",) in vehicle.commands


def test_return_home_restores_a_turn_not_yet_counted() -> None:
    plugin = ReturnHome()
    state = {"home": [0.0, 0.0, 0.0], "phase": "transit", "layer": 2, "land_wait": 60}
    plugin._drive_restore(state)
    assert plugin._drive_snapshot()["land_wait"] == 60.0
    with pytest.raises(ValueError, match="land_wait"):
        ReturnHome()._drive_restore({**state, "land_wait": -1})


def test_return_home_flies_home_lands_and_emits_once() -> None:
    vehicle = FakeVehicle(position=(30.0, 40.0, 15.0), cruise_speed=10.0, climb_rate=3.0)
    ctx = make_context(ReturnHome, params={"home": "0 0 0"}, vehicle=vehicle)
    plugin = ReturnHome()
    events = run_plugin(plugin, ctx, steps=100)
    assert events == []
    assert vehicle.commands[0] == ("goto", 0.0, 0.0, 20.0, None)
    events = run_plugin(plugin, ctx, steps=200)
    assert names(events) == ["landed_event"]
    assert ("land",) in vehicle.commands
    x, y, z = vehicle.position()
    assert math.hypot(x, y) <= 1.0 and z == 0.0
    assert plugin.phase == "done"


def test_return_home_defaults_to_where_it_started() -> None:
    vehicle = FakeVehicle(position=(7.0, -3.0, 0.0))
    ctx = make_context(ReturnHome, params={"altitude": "4"}, vehicle=vehicle)
    plugin = ReturnHome()
    plugin._drive_start(ctx)
    assert plugin.home == (7.0, -3.0, 0.0)
    assert plugin._drive_snapshot() == {"home": [7.0, -3.0, 0.0], "phase": "landing"}
    # Already down at home: it lands at once (the event) without flying anywhere.
    assert names(run_plugin(plugin, ctx, steps=3)) == ["landed_event"]


def test_return_home_without_landing_hovers_over_home() -> None:
    vehicle = FakeVehicle(position=(10.0, 0.0, 5.0))
    ctx = make_context(
        ReturnHome,
        params={"home": "0 0 0", "altitude": "5", "land": "false", "event": "home_event"},
        vehicle=vehicle,
    )
    events = run_plugin(ReturnHome(), ctx, steps=60)
    assert names(events) == ["home_event"]
    assert ("land",) not in vehicle.commands
    assert vehicle.commands[-1] == ("hold",)
    assert vehicle.position()[2] == pytest.approx(5.0)


def test_return_home_snapshot_restore_remembers_home() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 0.0))
    vehicle.goto(60.0, 0.0, 20.0)
    for _ in range(200):
        vehicle.advance(0.1)
    ctx = make_context(ReturnHome, vehicle=vehicle)
    vehicle.commands.clear()
    # Its first start is away from the origin: that is home.
    first = ReturnHome()
    first._drive_start(ctx)
    assert first.home == (60.0, 0.0, 20.0)
    vehicle.goto(0.0, 0.0, 20.0)  # another actor takes it away
    for _ in range(100):
        vehicle.advance(0.1)
    state = first._drive_snapshot()
    first._drive_stop(ctx)

    second = ReturnHome()
    second._drive_restore(state)
    second._drive_activate(ctx)
    assert vehicle.commands[-1] == ("goto", 60.0, 0.0, 20.0, None)
    events = run_plugin(second, ctx, steps=300)
    assert names(events) == ["landed_event"]
    assert math.hypot(vehicle.position()[0] - 60.0, vehicle.position()[1]) <= 1.0


def test_return_home_restore_refuses_an_unknown_phase() -> None:
    with pytest.raises(ValueError, match="phase"):
        ReturnHome()._drive_restore({"home": [0, 0, 0], "phase": "cruising"})


def fly_group_home(params: dict[str, str], *, rally: bool) -> tuple[float, list[ReturnHome]]:
    """Four vehicles in a line abreast 40 m apart, 1 km east of their homes, which lie in
    the reverse order: every straight path home crosses the others at one point, at the
    same instant. Fly them home together; the least 3-D distance between two of them until
    all are over home, and the plugins."""
    starts = [(1000.0, 40.0 * k, 80.0) for k in range(4)]
    homes = [f"0 {40.0 * (3 - k)} 0" for k in range(4)]
    vehicles = [FakeVehicle(position=p, cruise_speed=16.0, climb_rate=4.0) for p in starts]
    centre = [1000.0, 60.0]
    plugins, contexts = [], []
    for k, vehicle in enumerate(vehicles):
        ctx = make_context(
            ReturnHome,
            params={"home": homes[k], "land": "false", "tolerance": "2", **params},
            vehicle=vehicle,
            slot=k + 1,
            slots=4,
            data={"to": "Return", "slot": k + 1, "slots": 4, "centre": centre} if rally else None,
        )
        plugin = ReturnHome()
        plugin._drive_start(ctx)
        plugins.append(plugin)
        contexts.append(ctx)
    least = math.inf
    for _ in range(1500):
        for vehicle in vehicles:
            vehicle.advance(0.1)
        phases = set()
        for plugin, ctx in zip(plugins, contexts, strict=True):
            plugin._drive_step(ctx)
            ctx.drain()
            phases.add(plugin.phase)
        # The members leave the rally together: never one in rally and another beyond it.
        assert not ("rally" in phases and len(phases) > 1), phases
        positions = [v.position() for v in vehicles]
        least = min(
            least,
            *(math.dist(a, b) for i, a in enumerate(positions) for b in positions[i + 1 :]),
        )
        if phases == {"done"}:
            break
    return least, plugins


def test_return_home_straight_home_the_crossing_paths_meet() -> None:
    least, plugins = fly_group_home({"altitude": "80"}, rally=False)
    assert {p.phase for p in plugins} == {"done"}
    assert least < 1.0


def test_return_home_rally_keeps_the_shape_and_layers_keep_the_crossing_apart() -> None:
    """With a rally point the group flies there as it was (40 m apart) while each member
    climbs to its own layer (``layers`` 0: one per member), and only then crosses the
    others' paths to its home, about 12 m above or below each of them."""
    params = {"altitude": "80", "layer_step": "12", "layers": "0", "rally": "100 60 0"}
    least, plugins = fly_group_home(params, rally=True)
    assert {p.phase for p in plugins} == {"done"}
    assert least >= 11.0
    # Without the scattered centre (a release from an older master) it flies straight home.
    vehicle = FakeVehicle(position=(1000.0, 0.0, 80.0))
    alone = make_context(
        ReturnHome, params={"home": "0 0 0", **params}, vehicle=vehicle, slot=1, slots=4
    )
    plugin = ReturnHome()
    plugin._drive_start(alone)
    assert plugin.phase == "transit"
    assert vehicle.commands[-1] == ("goto", 0.0, 0.0, 80.0, None)


def test_return_home_rally_phase_snapshot_restores_the_place() -> None:
    vehicle = FakeVehicle(position=(500.0, 0.0, 50.0))
    ctx = make_context(
        ReturnHome,
        params={"home": "0 0 0", "rally": "100 0 0", "layer_step": "5"},
        vehicle=vehicle,
        slot=2,
        slots=3,
        data={"centre": [510.0, 0.0]},
    )
    plugin = ReturnHome()
    plugin._drive_start(ctx)
    state = plugin._drive_snapshot()
    assert state == {
        "home": [0.0, 0.0, 0.0],
        "phase": "rally",
        "layer": 1,
        "rally": [90.0, 0.0, 25.0],
        "rally_way": [-1.0, 0.0, 0.0],
    }
    second = ReturnHome()
    second._drive_restore(state)
    second._drive_activate(ctx)
    assert vehicle.commands[-1] == ("goto", 90.0, 0.0, 25.0, None)
    # Past the rally, a restored member goes home on its own layer.
    third = ReturnHome()
    third._drive_restore({"home": [0, 0, 0], "phase": "transit", "layer": 1})
    third._drive_activate(ctx)
    assert vehicle.commands[-1] == ("goto", 0.0, 0.0, 25.0, None)
    with pytest.raises(ValueError, match="layer"):
        ReturnHome()._drive_restore({"home": [0, 0, 0], "phase": "transit", "layer": -1})
    with pytest.raises(ValueError, match="rally"):
        ReturnHome()._drive_restore({"home": [0, 0, 0], "phase": "rally"})


# --- the whole mission in the simulated world's physics ------------------------------------------


def fly(
    world: World, plugin: Plugin, ctx: PluginContext, *, until: str, limit: float, dt: float = 0.1
) -> list[tuple[float, str]]:
    """Start ``plugin`` and step it with the world until it emits ``until``; stop it."""
    out: list[tuple[float, str]] = []
    plugin._drive_start(ctx)
    out.extend((ctx.now, e.event) for e in ctx.drain())
    end = ctx.now + limit
    while not any(name == until for _, name in out):
        assert ctx.now < end, f"no {until} within {limit} s; vehicle {world.vehicle(1)!r}"
        t = round(ctx.now + dt, 6)
        world.step_to(t)
        ctx.now = t
        plugin._drive_step(ctx)
        out.extend((t, e.event) for e in ctx.drain())
    plugin._drive_stop(ctx)
    return out


def test_quadrotor_mission_in_the_world() -> None:
    world = World(load_world(None), [1])
    vehicle = world.vehicle(1)
    assert (vehicle.kind, vehicle.mode) == ("quadrotor", "ground")
    home = vehicle.position()
    now = 0.0
    log: list[tuple[float, str]] = []

    ctx = make_context(TakeOff, params={"altitude": "20"}, vehicle=vehicle, now=now)
    log += fly(world, TakeOff(), ctx, until="ready_event", limit=60)
    assert abs(vehicle.position()[2] - 20.0) <= 1.0

    ctx = make_context(
        GoTo,
        params={"target": "-100 0 20"},
        transition_params={"TargetPoint": "100 0 20"},
        vehicle=vehicle,
        now=ctx.now,
    )
    log += fly(world, GoTo(), ctx, until="arriving_event", limit=120)
    assert math.dist(vehicle.position(), (100.0, 0.0, 20.0)) <= 5.0

    ctx = make_context(ReturnHome, params={"home": "0 0 0"}, vehicle=vehicle, now=ctx.now)
    log += fly(world, ReturnHome(), ctx, until="landed_event", limit=180)

    assert [name for _, name in log] == ["ready_event", "arriving_event", "landed_event"]
    times = [t for t, _ in log]
    assert times == sorted(times)
    assert world.fleet.mode(1) == "landed"
    x, y, z = vehicle.position()
    assert math.hypot(x - home[0], y - home[1]) <= 1.5 and z == 0.0
