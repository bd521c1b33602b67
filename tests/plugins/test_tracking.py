"""The detection and tracking plugins: the camera's footprint, the exclusive claim of a
target, following a moving target, losing it, the conformance kit, and a search-and-track
mission of three quadrotors in the simulated world."""

from __future__ import annotations

import math
from importlib.metadata import entry_points
from typing import Any

import pytest

from actorswarm.dsl import check
from actorswarm.plugins.tracking import UNSEEN_BID, DetectTarget, TrackTarget, track_role
from actorswarm.runtime.context import CameraUnavailable, CollectiveUnavailable, PluginContext
from actorswarm.runtime.events import Emitted
from actorswarm.sim.tasksim import TaskSim
from actorswarm.testing import FakeCamera, FakeVehicle, check_plugin, make_context, run_plugin
from actorswarm.world.config import loads_world


class FakeCollective:
    """Records the role claims and releases; the test answers them by appending to the
    blackboard's ``"collective"`` list, as the runtime does."""

    def __init__(self) -> None:
        self.claims: list[tuple[str, int, float | None]] = []
        self.releases: list[str] = []

    def barrier(
        self,
        key: int,
        need: int,
        *,
        bid: float | None = None,
        data: Any = None,
        renew: bool = False,
    ) -> int:
        raise AssertionError("no barriers expected")

    def claim_role(self, role: str, quota: int, *, bid: float | None = None) -> None:
        self.claims.append((role, quota, bid))

    def release_role(self, role: str) -> None:
        self.releases.append(role)


def answer(ctx: PluginContext, role: str, state: str) -> None:
    ctx.blackboard.setdefault("collective", []).append(
        {"kind": "role", "role": role, "state": state}
    )


def hovering(x: float = 0.0, y: float = 0.0, z: float = 20.0) -> FakeVehicle:
    return FakeVehicle(position=(x, y, z))


def names(events: list[Emitted]) -> list[str]:
    return [e.event for e in events]


# --- declarations and conformance ----------------------------------------------------------------


def test_entry_points_and_declarations() -> None:
    found = {ep.name: ep.load() for ep in entry_points(group="actorswarm.plugins")}
    assert found["detect.target"] is DetectTarget
    assert found["track.target"] is TrackTarget
    assert DetectTarget.bus == "observe_bus"
    assert DetectTarget.needs_vehicle is False
    assert DetectTarget.resources == frozenset()
    assert TrackTarget.bus == "act_bus"
    assert TrackTarget.needs_vehicle is True
    assert TrackTarget.resources == frozenset({"autopilot"})
    for cls in (DetectTarget, TrackTarget):
        assert all(param.doc for param in cls.params.values())
    assert track_role("jeep") == "track:jeep"


@pytest.mark.parametrize(
    "params",
    [{"exclusive": "false"}, {"exclusive": "false", "kind": "jeep", "scope": "swarm"}],
)
def test_detect_conformance(params: dict[str, str]) -> None:
    # The kit's camera looks down from 20 m over the origin: the jeep is in view.
    check_plugin(DetectTarget, params=params, camera_targets={"jeep": ("jeep", (5.0, 5.0, 0.0))})


@pytest.mark.parametrize(
    ("params", "targets"),
    [
        ({}, None),
        ({"lost_after": "1", "lost_event": "lost", "altitude": "5"}, None),
        ({"target": "jeep"}, {"jeep": (0.0, 0.0, 0.0)}),
    ],
)
def test_track_conformance(params: dict[str, str], targets: dict[str, Any] | None) -> None:
    check_plugin(TrackTarget, params=params, camera_targets=targets)


# --- detect.target -------------------------------------------------------------------------------


def test_detect_needs_a_camera() -> None:
    ctx = make_context(DetectTarget, params={"exclusive": "false"})
    with pytest.raises(CameraUnavailable, match="needs a camera"):
        DetectTarget()._drive_start(ctx)


def test_detection_respects_the_footprint() -> None:
    vehicle = hovering()  # 90°: the footprint is a disc of 20 m radius
    camera = FakeCamera(vehicle, {"far": (20.5, 0.0, 0.0)})
    ctx = make_context(DetectTarget, params={"exclusive": "false"}, camera=camera)
    plugin = DetectTarget()
    assert run_plugin(plugin, ctx, steps=10) == []
    assert "target" not in ctx.blackboard
    camera.targets["far"] = (19.5, 0.0, 0.0)
    events = run_plugin(plugin, ctx, steps=10)
    assert names(events) == ["target_detected_event"]
    (event,) = events
    assert event.scope == "local"
    assert event.bid == pytest.approx(math.hypot(19.5, 20.0))
    assert event.data == {"target": "far", "x": 19.5, "y": 0.0, "z": 0.0}
    assert plugin.fired


def test_detect_writes_the_nearest_match_to_the_blackboard_every_step() -> None:
    vehicle = hovering()
    camera = FakeCamera(
        vehicle,
        {"cow": ("cow", (1.0, 0.0, 0.0)), "jeep": ("jeep", (5.0, 5.0, 0.0)), "far": (9.0, 9, 0)},
    )
    ctx = make_context(DetectTarget, params={"kind": "jeep", "exclusive": "false"}, camera=camera)
    plugin = DetectTarget()
    events = run_plugin(plugin, ctx, steps=1)
    assert [e.data["target"] for e in events] == ["jeep"]
    first = ctx.blackboard["target"]
    assert first == {"name": "jeep", "kind": "jeep", "x": 5.0, "y": 5.0, "z": 0.0, "t": ctx.now}
    camera.targets["jeep"] = ("jeep", (6.0, 5.0, 0.0))
    assert run_plugin(plugin, ctx, steps=3) == []  # at most once per start
    assert ctx.blackboard["target"]["x"] == 6.0 and ctx.blackboard["target"]["t"] == ctx.now
    del camera.targets["jeep"]
    run_plugin(plugin, ctx, steps=3)
    assert ctx.blackboard["target"]["x"] == 6.0  # the last sighting stays


def test_detect_by_name() -> None:
    camera = FakeCamera(hovering(), {"a": (1.0, 0.0, 0.0), "b": (2.0, 0.0, 0.0)})
    ctx = make_context(DetectTarget, params={"target": "b", "exclusive": "false"}, camera=camera)
    events = run_plugin(DetectTarget(), ctx, steps=2)
    assert [e.data["target"] for e in events] == ["b"]


def test_exclusive_granted_emits_once_with_the_distance_as_bid() -> None:
    collective = FakeCollective()
    camera = FakeCamera(hovering(), {"jeep": (3.0, 4.0, 0.0)})
    ctx = make_context(DetectTarget, camera=camera, collective=collective)
    plugin = DetectTarget()
    assert run_plugin(plugin, ctx, steps=3) == []
    distance = math.dist((0.0, 0.0, 20.0), (3.0, 4.0, 0.0))
    assert collective.claims == [("track:jeep", 1, pytest.approx(distance))]
    answer(ctx, "track:other", "granted")  # not ours: ignored
    assert run_plugin(plugin, ctx, steps=2) == []
    answer(ctx, "track:jeep", "granted")
    events = run_plugin(plugin, ctx, steps=5)
    assert names(events) == ["target_detected_event"]
    assert events[0].bid == pytest.approx(distance)
    assert events[0].data == {"target": "jeep", "x": 3.0, "y": 4.0, "z": 0.0}
    assert len(collective.claims) == 1 and collective.releases == []
    assert run_plugin(plugin, ctx, steps=100) == []
    assert plugin._drive_snapshot() == {"fired": True}


def test_exclusive_denied_releases_and_retries_after_retry_seconds() -> None:
    collective = FakeCollective()
    camera = FakeCamera(hovering(), {"jeep": (3.0, 4.0, 0.0)})
    ctx = make_context(DetectTarget, params={"retry": "2"}, camera=camera, collective=collective)
    plugin = DetectTarget()
    run_plugin(plugin, ctx, steps=1)
    assert len(collective.claims) == 1
    answer(ctx, "track:jeep", "denied")
    assert run_plugin(plugin, ctx, steps=1) == []
    denied_at = ctx.now
    assert collective.releases == ["track:jeep"]
    assert plugin.next_deadline() == pytest.approx(denied_at + 2.0)
    # No new claim before `retry` seconds have passed...
    assert run_plugin(plugin, ctx, steps=19) == []
    assert len(collective.claims) == 1
    # ... then one, since the target is still in view.
    assert run_plugin(plugin, ctx, steps=2) == []
    assert len(collective.claims) == 2
    assert ctx.now - denied_at >= 2.0
    answer(ctx, "track:jeep", "granted")
    assert names(run_plugin(plugin, ctx, steps=1)) == ["target_detected_event"]


def test_exclusive_denied_then_out_of_view_does_not_claim_again() -> None:
    collective = FakeCollective()
    camera = FakeCamera(hovering(), {"jeep": (3.0, 4.0, 0.0)})
    ctx = make_context(DetectTarget, params={"retry": "1"}, camera=camera, collective=collective)
    plugin = DetectTarget()
    run_plugin(plugin, ctx, steps=1)
    answer(ctx, "track:jeep", "denied")
    run_plugin(plugin, ctx, steps=1)
    camera.targets.clear()
    assert run_plugin(plugin, ctx, steps=50) == []
    assert len(collective.claims) == 1
    assert plugin.next_deadline() is None  # no timer left in the past


def test_exclusive_without_an_answer_claims_again_after_retry() -> None:
    collective = FakeCollective()
    camera = FakeCamera(hovering(), {"jeep": (3.0, 4.0, 0.0)})
    ctx = make_context(DetectTarget, params={"retry": "1"}, camera=camera, collective=collective)
    run_plugin(DetectTarget(), ctx, steps=25)
    assert [c[0] for c in collective.claims] == ["track:jeep"] * 3  # at 0.1, 1.1 and 2.1 s


def test_a_pending_claim_is_released_on_pause_and_stop() -> None:
    collective = FakeCollective()
    camera = FakeCamera(hovering(), {"jeep": (3.0, 4.0, 0.0)})
    ctx = make_context(DetectTarget, camera=camera, collective=collective)
    plugin = DetectTarget()
    run_plugin(plugin, ctx, steps=1)
    plugin._drive_pause(ctx)
    assert collective.releases == ["track:jeep"]
    answer(ctx, "track:jeep", "granted")  # too late: this claim was withdrawn
    plugin._drive_activate(ctx)
    assert run_plugin(plugin, ctx, steps=1) == []
    assert len(collective.claims) == 2  # a fresh claim
    plugin._drive_stop(ctx)
    assert collective.releases == ["track:jeep", "track:jeep"]


def test_exclusive_without_a_swarm_fails_clearly() -> None:
    camera = FakeCamera(hovering(), {"jeep": (3.0, 4.0, 0.0)})
    ctx = make_context(DetectTarget, camera=camera)
    with pytest.raises(CollectiveUnavailable, match="exclusive=false"):
        run_plugin(DetectTarget(), ctx, steps=1)


def test_detect_restore() -> None:
    camera = FakeCamera(hovering(), {"jeep": (3.0, 4.0, 0.0)})
    ctx = make_context(DetectTarget, params={"exclusive": "false"}, camera=camera)
    fired = DetectTarget()
    fired._drive_restore({"fired": True})
    fired._drive_activate(ctx)
    assert run_plugin(fired, ctx, steps=5) == []
    fresh = DetectTarget()
    fresh._drive_restore({"fired": False})
    fresh._drive_activate(ctx)
    assert names(run_plugin(fresh, ctx, steps=1)) == ["target_detected_event"]
    with pytest.raises(ValueError, match="fired"):
        DetectTarget()._drive_restore({"fired": "yes"})


# --- track.target --------------------------------------------------------------------------------


def chase(
    plugin: TrackTarget,
    ctx: PluginContext,
    camera: FakeCamera,
    route: Any,
    *,
    seconds: float,
    dt: float = 0.1,
) -> list[Emitted]:
    """Step the tracker while the target moves along ``route(t)`` (None: out of sight)."""
    out: list[Emitted] = []
    for _ in range(round(seconds / dt)):
        where = route(ctx.now + dt)
        if where is None:
            camera.targets.pop("jeep", None)
        else:
            camera.targets["jeep"] = ("jeep", where)
        out += run_plugin(plugin, ctx, steps=1, dt=dt)
    return out


def test_tracker_follows_a_moving_target() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 20.0), cruise_speed=5.0)
    camera = FakeCamera(vehicle, {"jeep": ("jeep", (10.0, 0.0, 0.0))})
    ctx = make_context(TrackTarget, vehicle=vehicle, camera=camera, collective=FakeCollective())
    plugin = TrackTarget()
    plugin._drive_start(ctx)
    assert vehicle.commands[0][:4] == ("goto", 10.0, 0.0, 20.0)

    def drive(t: float) -> tuple[float, float, float]:  # 4 m/s east, then north
        return (10.0 + 4.0 * min(t, 15.0), 4.0 * max(0.0, t - 15.0), 0.0)

    chase(plugin, ctx, camera, drive, seconds=30.0)
    x, y, z = vehicle.position()
    tx, ty, _ = drive(ctx.now)
    assert math.hypot(x - tx, y - ty) < 3.0
    assert z == pytest.approx(20.0)
    assert not plugin.lost
    gotos = [c for c in vehicle.commands if c[0] == "goto"]
    assert len(gotos) < 300 / 2  # only when the point moved a metre or more
    assert max(c[4] for c in gotos) > 4.0  # the target's speed, plus catching up


def test_tracker_claims_the_role_once_and_releases_it_on_stop() -> None:
    collective = FakeCollective()
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"jeep": (1.0, 0.0, 0.0)})
    ctx = make_context(TrackTarget, vehicle=vehicle, camera=camera, collective=collective)
    plugin = TrackTarget()
    run_plugin(plugin, ctx, steps=10)
    # Bidding its horizontal distance to the jeep, 1 m off.
    assert collective.claims == [("track:jeep", 1, pytest.approx(1.0))]
    plugin._drive_stop(ctx)
    assert collective.releases == ["track:jeep"]
    # Without a swarm, and with exclusive off, no claim (and no error).
    run_plugin(TrackTarget(), make_context(TrackTarget, vehicle=hovering(), camera=camera), steps=3)
    quiet = FakeCollective()
    ctx = make_context(
        TrackTarget,
        params={"exclusive": "false"},
        vehicle=vehicle,
        camera=camera,
        collective=quiet,
    )
    run_plugin(TrackTarget(), ctx, steps=3)
    assert quiet.claims == []


LOST_TRACKER = {
    "to": "Track",
    "slot": 1,
    "slots": 1,
    "event": {"platform": 9, "at": [600.0, 50.0, 15.0], "roles": ["other", "track:jeep"]},
}


def test_a_tracker_promoted_by_x_lost_claims_the_lost_tracker_s_role_at_once() -> None:
    """Before it has seen anything: a searcher that sees the jeep meanwhile is denied."""
    collective = FakeCollective()
    vehicle = hovering()
    ctx = make_context(
        TrackTarget,
        params={"area": "0 0 100 100"},
        vehicle=vehicle,
        camera=FakeCamera(vehicle),
        collective=collective,
        data=LOST_TRACKER,
    )
    plugin = TrackTarget()
    plugin._drive_start(ctx)
    # Not seen yet: of two holders after a heal, the one that sees the jeep keeps it.
    assert collective.claims == [("track:jeep", 1, UNSEEN_BID)]
    assert plugin.last is None, "the lost tracker's position is not the target's"


def test_a_promoted_tracker_looks_where_the_lost_one_was_then_sweeps_from_there() -> None:
    vehicle = FakeVehicle(position=(10.0, 10.0, 30.0), cruise_speed=10.0)
    camera = FakeCamera(vehicle)
    params = {"area": "0 0 100 100", "search_altitude": "30", "altitude": "15"}
    lost = {"platform": 9, "at": [90.0, 20.0, 15.0], "roles": ["track:jeep"]}
    data = {"to": "Track", "slot": 1, "slots": 1, "event": lost}
    ctx = make_context(
        TrackTarget,
        params=params,
        vehicle=vehicle,
        camera=camera,
        collective=FakeCollective(),
        data=data,
    )
    plugin = TrackTarget()
    plugin._drive_start(ctx)
    assert vehicle.commands[-1] == ("goto", 90.0, 20.0, 30.0, None)
    run_plugin(plugin, ctx, steps=120, dt=0.1)  # there, and on to the nearest lane end
    x, y, _ = vehicle.position()
    assert x > 50.0, f"the sweep goes on from the eastern lanes, not from the start: {x, y}"
    # The target near where the lost tracker was is found.
    camera.targets["jeep"] = ("jeep", (x, y, 0.0))
    run_plugin(plugin, ctx, steps=5)
    assert plugin.last == (x, y, 0.0)


@pytest.mark.parametrize(
    ("params", "event"),
    [
        ({"target": "car"}, LOST_TRACKER["event"]),  # another target than it is after
        ({}, {"platform": 9, "at": None, "roles": ["track:"]}),
        ({}, {"platform": 9, "at": None, "roles": "track:jeep"}),  # not a list
        ({}, 9),  # a bare ID
    ],
)
def test_a_promoted_tracker_claims_nothing_without_a_tracker_role_to_take_over(
    params: dict[str, str], event: Any
) -> None:
    collective = FakeCollective()
    vehicle = hovering()
    ctx = make_context(
        TrackTarget,
        params=params,
        vehicle=vehicle,
        camera=FakeCamera(vehicle),
        collective=collective,
        data={"to": "Track", "slot": 1, "slots": 1, "event": event},
    )
    run_plugin(TrackTarget(), ctx, steps=3)
    assert [c[0] for c in collective.claims] == (["track:car"] if params else [])


@pytest.mark.parametrize("state", ["denied", "revoked"])
def test_a_tracker_refused_the_role_yields_once(state: str) -> None:
    collective = FakeCollective()
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"jeep": ("jeep", (1.0, 0.0, 0.0))})
    params = {"yield_event": "track_yield_event"}
    ctx = make_context(
        TrackTarget, params=params, vehicle=vehicle, camera=camera, collective=collective
    )
    plugin = TrackTarget()
    assert run_plugin(plugin, ctx, steps=5) == []
    answer(ctx, "track:other", state)  # not its role
    answer(ctx, "track:jeep", "granted")
    assert run_plugin(plugin, ctx, steps=5) == [], "granted (or another role's answer): stays"
    answer(ctx, "track:jeep", state)
    events = run_plugin(plugin, ctx, steps=5)
    assert names(events) == ["track_yield_event"] and events[0].scope == "local"
    answer(ctx, "track:jeep", state)
    assert run_plugin(plugin, ctx, steps=5) == [], "once per start"


def test_without_a_yield_event_a_refused_tracker_keeps_tracking() -> None:
    collective = FakeCollective()
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"jeep": ("jeep", (1.0, 0.0, 0.0))})
    ctx = make_context(TrackTarget, vehicle=vehicle, camera=camera, collective=collective)
    plugin = TrackTarget()
    run_plugin(plugin, ctx, steps=5)
    answer(ctx, "track:jeep", "denied")
    assert run_plugin(plugin, ctx, steps=5) == []
    assert plugin.last == (1.0, 0.0, 0.0)


def test_an_answer_from_before_the_claim_is_not_the_claim_s() -> None:
    collective = FakeCollective()
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"jeep": ("jeep", (1.0, 0.0, 0.0))})
    params = {"yield_event": "track_yield_event"}
    ctx = make_context(
        TrackTarget, params=params, vehicle=vehicle, camera=camera, collective=collective
    )
    answer(ctx, "track:jeep", "denied")  # what the detector of this actor was told before
    assert run_plugin(TrackTarget(), ctx, steps=5) == []


def test_tracker_keeps_to_the_target_it_locked_on() -> None:
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"a": (2.0, 0.0, 0.0)})
    ctx = make_context(TrackTarget, vehicle=vehicle, camera=camera)
    plugin = TrackTarget()
    run_plugin(plugin, ctx, steps=20)
    camera.targets["b"] = (0.5, 0.0, 0.0)  # nearer, but not the one
    camera.targets["a"] = (-3.0, 0.0, 0.0)
    run_plugin(plugin, ctx, steps=50)
    assert plugin.last == (-3.0, 0.0, 0.0)


def test_lost_event_after_lost_after_seconds() -> None:
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"jeep": ("jeep", (2.0, 0.0, 0.0))})
    params = {"lost_after": "4", "lost_event": "jeep_lost"}
    ctx = make_context(TrackTarget, params=params, vehicle=vehicle, camera=camera)
    plugin = TrackTarget()
    run_plugin(plugin, ctx, steps=10)
    seen_at = ctx.now
    events = chase(plugin, ctx, camera, lambda t: None, seconds=3.9)
    assert events == [] and not plugin.lost
    events = chase(plugin, ctx, camera, lambda t: None, seconds=0.2)
    assert names(events) == ["jeep_lost"] and events[0].scope == "local"
    assert ctx.now - seen_at >= 4.0
    assert plugin._drive_snapshot() == {"last": [2.0, 0.0, 0.0], "seen_at": seen_at, "lost": True}
    assert chase(plugin, ctx, camera, lambda t: None, seconds=20.0) == []  # once per loss
    # Hovering over the last known position all along.
    x, y, _ = vehicle.position()
    assert math.hypot(x - 2.0, y) < 0.01
    # Seen again: no longer lost.
    chase(plugin, ctx, camera, lambda t: (3.0, 0.0, 0.0), seconds=0.5)
    assert not plugin.lost


def test_nothing_known_holds_and_waits() -> None:
    vehicle = hovering()
    ctx = make_context(TrackTarget, params={"lost_event": "gone"}, vehicle=vehicle)
    plugin = TrackTarget()
    events = run_plugin(plugin, ctx, steps=50)
    assert vehicle.commands == [("hold",)]
    assert names(events) == []  # 5 s: not lost yet (lost_after 10)
    assert names(run_plugin(plugin, ctx, steps=60)) == ["gone"]


@pytest.mark.parametrize(
    "data",
    [
        {"x": 30.0, "y": -10.0, "target": "jeep"},
        {"to": "Track", "slot": 1, "slots": 1, "event": {"x": 30, "y": -10}},
    ],
)
def test_tracker_starts_from_the_position_the_transition_brought(data: dict[str, Any]) -> None:
    vehicle = hovering()
    ctx = make_context(TrackTarget, params={"altitude": "15"}, vehicle=vehicle, data=data)
    plugin = TrackTarget()
    run_plugin(plugin, ctx, steps=1)
    assert vehicle.commands[0][:4] == ("goto", 30.0, -10.0, 15.0)
    assert plugin.last == (30.0, -10.0, 0.0)


def test_tracker_reads_a_newer_blackboard_sighting() -> None:
    vehicle = hovering()
    blackboard: dict[str, Any] = {
        "target": {"name": "jeep", "kind": "jeep", "x": 40.0, "y": 0.0, "z": 0.0, "t": 0.0}
    }
    ctx = make_context(TrackTarget, vehicle=vehicle, blackboard=blackboard)
    plugin = TrackTarget()
    run_plugin(plugin, ctx, steps=1)
    assert vehicle.commands[0][:4] == ("goto", 40.0, 0.0, 20.0)
    blackboard["target"] = {**blackboard["target"], "x": 50.0, "t": ctx.now}
    run_plugin(plugin, ctx, steps=1)
    assert vehicle.commands[-1][:4] == ("goto", 50.0, 0.0, 20.0)
    # Another kind is not this tracker's.
    other = make_context(
        TrackTarget, params={"kind": "cow"}, vehicle=hovering(), blackboard=blackboard
    )
    assert TrackTarget().snapshot()["last"] is None
    tracker = TrackTarget()
    run_plugin(tracker, other, steps=1)
    assert tracker.last is None


def test_tracker_restores_and_flies_to_the_last_position() -> None:
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"jeep": (5.0, 5.0, 0.0)})
    ctx = make_context(TrackTarget, vehicle=vehicle, camera=camera, now=50.0)
    first = TrackTarget()
    run_plugin(first, ctx, steps=3)
    state = first._drive_snapshot()
    assert state == {"last": [5.0, 5.0, 0.0], "seen_at": pytest.approx(50.3), "lost": False}
    first._drive_stop(ctx)

    elsewhere = FakeVehicle(position=(100.0, 100.0, 20.0))
    later = make_context(TrackTarget, vehicle=elsewhere, now=52.0)  # no camera now
    second = TrackTarget()
    second._drive_restore(state)
    assert second._drive_snapshot() == state
    second._drive_activate(later)
    assert elsewhere.commands[0][:4] == ("goto", 5.0, 5.0, 20.0)


def test_tracker_counts_down_across_a_reboot_on_the_task_clock() -> None:
    """A tracker restored on a new clock (its robot rebooted) goes on with the lost
    countdown from its last sighting in the task's time."""
    vehicle = hovering()
    camera = FakeCamera(vehicle, {"jeep": ("jeep", (2.0, 0.0, 0.0))})
    params = {"lost_after": "10", "lost_event": "jeep_lost"}
    ctx = make_context(
        TrackTarget, params=params, vehicle=vehicle, camera=camera, now=7000.0, task_start=6000.0
    )
    first = TrackTarget()
    run_plugin(first, ctx, steps=5)
    state = first._drive_snapshot()
    assert state["seen_after_task"] == pytest.approx(1000.5)
    assert state["seen_at"] - 6000.0 == pytest.approx(state["seen_after_task"])

    # The new clock reads 30 s at 1004.5 s of the task: 4 s since the last sighting.
    elsewhere = hovering()
    later = make_context(
        TrackTarget, params=params, vehicle=elsewhere, now=30.0, task_start=30.0 - 1004.5
    )
    second = TrackTarget()
    second._drive_restore(state)
    assert second._drive_snapshot()["seen_after_task"] == state["seen_after_task"]
    second._drive_activate(later)
    assert names(run_plugin(second, later, steps=55)) == []  # 9.5 s since the sighting
    assert names(run_plugin(second, later, steps=10)) == ["jeep_lost"]
    with pytest.raises(ValueError, match="seen_after_task"):
        TrackTarget()._drive_restore({**state, "seen_after_task": [1]})


@pytest.mark.parametrize(
    "state",
    [
        {"last": [1, 2], "seen_at": None, "lost": False},
        {"last": None, "seen_at": "now", "lost": False},
        {"last": None, "seen_at": None, "lost": None},
        {},
    ],
)
def test_tracker_restore_refuses_a_bad_snapshot(state: dict[str, Any]) -> None:
    with pytest.raises(ValueError, match=r"track\.target: a snapshot's"):
        TrackTarget()._drive_restore(state)


# --- three quadrotors search, one tracks ---------------------------------------------------------

WORLD = """
[fleet]
spacing = 10.0

[[targets]]
name = "jeep"
kind = "jeep"
route = [[80.0, 130.0]]
speed = 0.0

[[areas]]
name = "field"
rect = [0.0, 60.0, 120.0, 160.0]
"""

SCRIPT = """<TaskScript name="search-and-track" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Standby</_P_Name><OODAConfig>
      <Bus><_P_Name>act_bus</_P_Name>
        <Plugin><_P_Name>flight.takeoff</_P_Name><param key="altitude" value="20"/></Plugin>
      </Bus>
    </OODAConfig></Actor>
    <Actor><_P_Name>Search</_P_Name><OODAConfig>
      <Bus><_P_Name>observe_bus</_P_Name>
        <Plugin><_P_Name>detect.target</_P_Name>
          <param key="kind" value="jeep"/><param key="exclusive" value="EXCLUSIVE"/>
        </Plugin>
      </Bus>
      <Bus><_P_Name>act_bus</_P_Name>
        <Plugin><_P_Name>search.area</_P_Name><param key="area" value="field"/></Plugin>
      </Bus>
    </OODAConfig></Actor>
    <Actor><_P_Name>Track</_P_Name><OODAConfig>
      <Bus><_P_Name>act_bus</_P_Name>
        <Plugin><_P_Name>track.target</_P_Name><param key="kind" value="jeep"/></Plugin>
      </Bus>
    </OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="Standby">
      <transition name="ready_event" barrierKey="1" sysNum="all">
        <successor actor="Search"/>
      </transition>
    </actor>
    <actor name="Search">
      <transition name="target_detected_event" barrierKey="2" sysNum="1">
        <successor actor="Track"/>
      </transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-3" actor="Standby"/></_PlatformActorConfig>
</TaskScript>
"""


@pytest.mark.parametrize(("exclusive", "trackers"), [("true", 1), ("false", 2)])
def test_three_quadrotors_search_and_one_tracks(exclusive: str, trackers: int) -> None:
    """The jeep stands on the line between two strips, so two searchers see it; with
    exclusive detection only the first to claim it becomes its tracker."""
    result = check(SCRIPT.replace("EXCLUSIVE", exclusive), path="search_and_track.xml")
    assert result.script is not None, [str(d) for d in result.diagnostics]
    sim = TaskSim(result.script, seed=1, world_config=loads_world(WORLD))
    report = sim.run(90.0)
    # Two trackers of one jeep hover over it together: a breach the run reports, and why
    # detection is exclusive in the shipped missions.
    breaches = report["separation"]["breaches"]
    assert [b["platforms"] for b in breaches] == ([] if trackers == 1 else [[1, 2]])
    assert len(report["violations"]) == len(breaches) and report["plugin_failures"] == []
    moves = [(t["from"], t["to"]) for t in report["transitions"] if t["from"]]
    assert moves.count(("Standby", "Search")) == 3
    assert moves.count(("Search", "Track")) == trackers
    tracking = [int(p) for p, actors in report["final_actors"].items() if actors == ["Track"]]
    assert len(tracking) == trackers
    assert sim.world is not None
    for p in tracking:
        x, y, z = sim.world.vehicle(p).position()
        assert math.hypot(x - 80.0, y - 130.0) < 2.0, f"platform {p} is not over the jeep"
        assert z == pytest.approx(20.0, abs=1.0)


def test_a_tracker_that_knows_nothing_sweeps_its_area_until_it_sees_the_target() -> None:
    """What a tracker promoted by Track_lost does: it sweeps the area from the lane end
    nearest to it, and follows the target once its camera sees it."""
    vehicle = FakeVehicle(position=(95.0, 95.0, 30.0), cruise_speed=10.0)
    camera = FakeCamera(vehicle, {"jeep": ("jeep", (20.0, 80.0, 0.0))})
    params = {"area": "0 0 100 100", "search_altitude": "30", "altitude": "15"}
    ctx = make_context(
        TrackTarget, params=params, vehicle=vehicle, camera=camera, collective=FakeCollective()
    )
    plugin = TrackTarget()
    plugin._drive_start(ctx)
    first = vehicle.commands[-1]
    assert first[0] == "goto" and first[3] == 30.0
    # The nearest lane end to (95, 95) is on the eastern lane, at the north edge.
    assert first[1] > 50.0 and first[2] == pytest.approx(100.0)
    run_plugin(plugin, ctx, steps=600, dt=0.1)  # a minute: the sweep reaches the jeep
    x, y, z = vehicle.position()
    assert math.hypot(x - 20.0, y - 80.0) < 2.0 and z == pytest.approx(15.0)
    assert plugin.last == (20.0, 80.0, 0.0)


def test_a_tracker_without_an_area_hovers_until_told() -> None:
    vehicle = FakeVehicle(position=(0.0, 0.0, 20.0))
    ctx = make_context(TrackTarget, vehicle=vehicle, camera=FakeCamera(vehicle))
    plugin = TrackTarget()
    run_plugin(plugin, ctx, steps=20)
    assert [c[0] for c in vehicle.commands] == ["hold"]
