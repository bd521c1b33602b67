"""End to end over UDP loopback: MavlinkVehicle flies the simulated autopilot (ArduPilot and
PX4 flavours) through take-off, goto and landing, in real time; PX4's offboard timeout."""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Iterator
from typing import Any, Literal

import pytest
from tests.vehicles.helpers import free_port, wait_for, wait_started

from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.vehicle import MavlinkSettings, MavlinkVehicle

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)
#: The autopilot stands 20 m east and 10 m south of the mission origin.
HOME = (20.0, -10.0, 0.0)


Flight = tuple[MavlinkVehicle, SimAutopilot]


@contextlib.contextmanager
def fly(
    kind: Literal["ardupilot", "px4"],
    *,
    arm_timeout: float = 120.0,
    settings: dict[str, Any] | None = None,
    **autopilot: object,
) -> Iterator[Flight]:
    """The vehicle (``settings``: more of its MavlinkSettings) flying a simulated autopilot
    of ``kind`` (``autopilot``: more of its options; it is ready after 1 s unless told)."""
    port = free_port()
    options = AutopilotOptions(
        f"udpin:127.0.0.1:{port}",
        MissionFrame(*ORIGIN.to_geodetic(*HOME)),
        system=7,
        kind=kind,
        **{"ready_after": 1.0, **autopilot},  # type: ignore[arg-type]
    )
    sim = SimAutopilot(options)
    stop = threading.Event()
    thread = threading.Thread(target=sim.run, args=(stop,), daemon=True)
    thread.start()
    vehicle = MavlinkVehicle(
        MavlinkSettings(
            f"udpout:127.0.0.1:{port}",
            ORIGIN,
            system=7,
            name="platform 1",
            arm_timeout=arm_timeout,
            **(settings or {}),
        )
    )
    vehicle.start()
    try:
        yield vehicle, sim
    finally:
        vehicle.close()
        stop.set()
        thread.join(timeout=2)
        sim.close()


@pytest.fixture(params=["ardupilot", "px4"])
def flight(request: pytest.FixtureRequest) -> Iterator[Flight]:
    with fly(request.param) as pair:
        yield pair


def near(a: tuple[float, float, float], b: tuple[float, float, float], tol: float) -> bool:
    return math.dist(a, b) <= tol


def test_takeoff_goto_land(flight: Flight) -> None:
    vehicle, sim = flight
    wait_for("the first position", lambda: vehicle.status()["mode"] != "", 3.0)
    wait_for("the first position", lambda: vehicle.located, 3.0)
    assert near(vehicle.position(), HOME, 0.05)
    assert vehicle.status()["autopilot"] == sim.options.kind
    wait_for("the failsafe parameters", lambda: vehicle.failsafes() is True, 3.0)

    wait_started(vehicle)
    vehicle.takeoff(4.0)
    wait_for("the climb", lambda: vehicle.position()[2] > 3.8, 8.0)
    assert sim.armed
    assert near(vehicle.position(), (HOME[0], HOME[1], 4.0), 0.5)

    goal = (HOME[0] + 8.0, HOME[1] + 4.0, 6.0)
    vehicle.goto(*goal, speed=4.0)
    wait_for("the goal", lambda: near(vehicle.position(), goal, 0.5), 10.0)
    assert sim.mode_name == ("GUIDED" if sim.options.kind == "ardupilot" else "OFFBOARD")
    # The autopilot's own frame agrees with ours: 8 m east, 4 m north, 6 m up from its home.
    assert near(sim.position(), (8.0, 4.0, 6.0), 0.6)

    vehicle.land()
    wait_for("the landing", lambda: not sim.armed, 10.0)
    assert vehicle.position()[2] == pytest.approx(0.0, abs=0.1)
    wait_for("the disarm seen", lambda: not vehicle.armed, 3.0)
    assert vehicle.drain_errors() == []
    assert vehicle.drain_events() == []


def test_px4_holds_when_offboard_setpoints_stop() -> None:
    with fly("px4", offboard_timeout=0.5) as (vehicle, sim):
        wait_for("the failsafe parameters", lambda: vehicle.failsafes() is True, 3.0)
        wait_started(vehicle)
        vehicle.takeoff(2.0)
        wait_for("the climb", lambda: vehicle.position()[2] > 1.8, 6.0)
        vehicle.goto(HOME[0] + 30.0, HOME[1], 2.0)
        wait_for("offboard", lambda: sim.mode_name == "OFFBOARD", 3.0)
        vehicle.close()  # the companion computer dies: no more setpoints
        wait_for("the offboard failsafe", lambda: sim.mode_name == "AUTO.LOITER", 3.0)
        x = sim.position()[0]
        time.sleep(1.0)
        assert abs(sim.position()[0] - x) < 1.5  # it holds instead of flying on
        assert sim.position()[0] < 25.0


def test_refused_takeoff_is_reported() -> None:
    with fly("ardupilot", failsafes=False) as (vehicle, sim):
        wait_for("the failsafe parameters", lambda: vehicle.failsafes() is not None, 3.0)
        wait_started(vehicle)
        vehicle.takeoff(3.0)
        time.sleep(0.3)
        errors = vehicle.drain_errors()
        assert any("FS_GCS_ENABLE is 0" in e and "refusing to arm" in e for e in errors), errors
        assert not sim.armed
        # A final failure: the daemon raises vehicle_fault_event with it.
        faults = vehicle.drain_faults()
        assert len(faults) == 1 and "FS_GCS_ENABLE is 0" in faults[0]


def test_a_goto_right_after_the_takeoff_does_not_take_off_again() -> None:
    with fly("ardupilot") as (vehicle, _):
        wait_for("the failsafe parameters", lambda: vehicle.failsafes() is True, 3.0)
        wait_started(vehicle)
        vehicle.takeoff(3.0)
        wait_for("the take-off accepted", lambda: vehicle.status()["plan"] is None, 3.0)
        goal = (HOME[0] + 3.0, HOME[1], 3.0)
        vehicle.goto(*goal)  # still low in the climb
        wait_for("the goal", lambda: near(vehicle.position(), goal, 0.5), 10.0)
        assert vehicle.drain_errors() == []


def test_the_operator_s_hold_overrides_the_plugins_until_resumed() -> None:
    with fly("ardupilot") as (vehicle, sim):
        wait_for("the failsafe parameters", lambda: vehicle.failsafes() is True, 3.0)
        wait_started(vehicle)
        vehicle.takeoff(3.0)
        wait_for("the climb", lambda: vehicle.position()[2] > 2.8, 6.0)
        vehicle.goto(HOME[0] + 40.0, HOME[1], 3.0, speed=4.0)
        wait_for("under way", lambda: vehicle.velocity()[0] > 2.0, 5.0)
        vehicle.override("hold")
        wait_for("stopped", lambda: abs(vehicle.velocity()[0]) < 0.1, 5.0)
        # The telemetry says stopped; let the airframe itself settle (a loaded machine
        # delays the telemetry) before measuring that the hold holds.
        last = [sim.position()[0]]

        def settled() -> bool:
            time.sleep(0.25)
            now_x = sim.position()[0]
            still = abs(now_x - last[0]) < 0.03
            last[0] = now_x
            return still

        wait_for("the airframe at rest", settled, 5.0)
        x = sim.position()[0]
        for _ in range(3):
            vehicle.goto(HOME[0] + 40.0, HOME[1], 3.0)  # a plugin insists
        assert vehicle.drain_errors() == [
            "vehicle platform 1: goto ignored: the operator's hold holds the vehicle until "
            "vehicle_resume"
        ]
        time.sleep(0.5)
        assert abs(sim.position()[0] - x) < 0.2 and vehicle.status()["override"] == "hold"
        vehicle.override(None)
        vehicle.goto(HOME[0] + 3.0, HOME[1] + 3.0, 3.0)
        wait_for("the plugins' goal again", lambda: sim.position()[1] > 2.5, 6.0)


@pytest.mark.parametrize("kind", ["ardupilot", "px4"])
def test_a_takeoff_waits_until_the_autopilot_is_ready_and_says_why(
    kind: Literal["ardupilot", "px4"],
) -> None:
    with fly(kind, ready_after=4.0) as (vehicle, sim):
        wait_for("the autopilot heard", lambda: vehicle.status()["autopilot"] == kind, 3.0)
        vehicle.takeoff(2.0)  # at once, as an operator starting a script would
        # The autopilot's own words (PX4's too: the vehicle speaks as a ground station).
        words = ("PreArm: ", "Arm: ") if kind == "ardupilot" else ("Preflight Fail", "Arming")
        wait_for(
            "the autopilot's reason",
            lambda: str(vehicle.status()["reason"]).startswith(words),
            3.0,
        )
        wait_for("the take-off waiting", lambda: (vehicle.status()["waiting"] or 0) > 0.2, 3.0)
        assert vehicle.status()["ready"] is False and not sim.armed
        wait_for("the climb", lambda: vehicle.position()[2] > 1.8, 10.0)
        assert sim.boot_time(time.monotonic()) >= 4.0
        status = vehicle.status()
        assert (status["ready"], status["waiting"], status["reason"]) == (True, None, None)
        assert vehicle.drain_errors() == []
        log = [event for event, _ in vehicle.drain_log()]
        assert "vehicle-waiting" in log and "vehicle-ready" in log


def test_a_copter_take_off_asked_before_its_autopilot_is_heard_flies_once_it_is() -> None:
    """ArduCopter at its measured pace, on the test's clock: the take-off, asked before its
    first HEARTBEAT (0.96 s), is planned 3 s after it, once its start-up is over. Planned
    at once, GUIDED was lost at "ArduPilot Ready" (2.2 s), as on the firmware; the copter
    armed in STABILIZE, and NAV_TAKEOFF (or GUIDED asked again, armed without a position)
    was refused: it never left the ground."""
    clock = [500.0]
    port = free_port()
    sim = SimAutopilot(
        AutopilotOptions(
            f"udpin:127.0.0.1:{port}", MissionFrame(*ORIGIN.to_geodetic(*HOME)), system=7
        ),
        clock=lambda: clock[0],
    )
    vehicle = MavlinkVehicle(
        MavlinkSettings(f"udpout:127.0.0.1:{port}", ORIGIN, system=7, name="platform 1"),
        clock=lambda: clock[0],
    )
    try:
        vehicle.takeoff(5.0)
        modes = []
        while clock[0] < 560.0 and vehicle.position()[2] < 4.5:
            clock[0] += 0.02
            sim.service(clock[0])
            vehicle.service(clock[0])
            if not modes or modes[-1] != sim.mode_name:
                modes.append(sim.mode_name)
        assert vehicle.position()[2] >= 4.5, (modes, vehicle.drain_errors())
        assert modes == ["STABILIZE", "GUIDED"], modes  # GUIDED once, kept
        assert vehicle.drain_faults() == []
    finally:
        vehicle.close()
        sim.close()


def test_an_autopilot_that_never_becomes_ready_fails_the_takeoff_with_its_reason() -> None:
    with fly("ardupilot", ready_after=60.0, arm_timeout=2.0) as (vehicle, sim):
        wait_started(vehicle)
        vehicle.takeoff(2.0)
        errors: list[str] = []

        def failed() -> bool:
            errors.extend(vehicle.drain_errors())
            return bool(errors)

        wait_for("the failure", failed, 5.0)
        # The autopilot was asked (readiness is advice) and refused with its own words (its
        # refusal's, or its pre-arm nag's since: the latest it said).
        assert len(errors) == 1, errors
        head = (
            "vehicle platform 1: takeoff: MAV_CMD_COMPONENT_ARM_DISARM: not done within 2 s "
            "(1 try), last refused: MAV_RESULT_FAILED — "
        )
        assert errors[0] in (
            head + "Arm: AHRS: waiting for home",
            head + "PreArm: AHRS: waiting for home",
        ), errors
        assert not sim.armed and vehicle.status()["waiting"] is None


@pytest.mark.parametrize("kind", ["ardupilot", "px4"])
def test_a_hold_then_a_new_goal_at_once_flies_to_the_new_goal(
    kind: Literal["ardupilot", "px4"],
) -> None:
    """An actor switch between two moving actors: the outgoing one holds (its goto
    arrived), the incoming one sends its goal in the same instant. The hold must never
    cancel the new goal (PX4: its AUTO.LOITER must not land after the new OFFBOARD)."""
    with fly(kind) as (vehicle, sim):
        wait_for("the failsafe parameters", lambda: vehicle.failsafes() is True, 3.0)
        wait_started(vehicle)
        vehicle.takeoff(2.0)
        wait_for("the climb", lambda: vehicle.position()[2] > 1.8, 8.0)
        first = (HOME[0] + 4.0, HOME[1], 2.0)
        vehicle.goto(*first)
        wait_for("the first goal", lambda: near(vehicle.position(), first, 0.5), 10.0)
        wait_for("its mode reported", lambda: vehicle.mode in ("GUIDED", "OFFBOARD"), 3.0)
        vehicle.hold()  # the outgoing actor
        second = (HOME[0], HOME[1] + 4.0, 2.0)
        vehicle.goto(*second)  # the incoming actor, in the same step
        wait_for(
            "the second goal",
            lambda: near(vehicle.position(), second, 0.5),
            10.0,
        )
        assert sim.mode_name == ("GUIDED" if kind == "ardupilot" else "OFFBOARD")
        assert vehicle.drain_errors() == []


def test_an_arducopter_whose_failsafe_watches_another_ground_station_is_not_armed() -> None:
    """ArduCopter's link-loss failsafe counts only SYSID_MYGCS's heartbeats and starts only
    once it heard one: watching another system, FS_GCS_ENABLE 1 guards nothing."""
    with fly("ardupilot", settings={"own_system": 200}) as (vehicle, sim):
        wait_for("the failsafe check", lambda: vehicle.failsafes() is not None, 3.0)
        why = vehicle.failsafes()
        assert isinstance(why, str) and why.startswith("SYSID_MYGCS is 245, not this vehicle's"), (
            why
        )
        wait_started(vehicle)
        vehicle.takeoff(4.0)
        wait_for("the refusal", lambda: bool(vehicle.drain_faults()), 3.0)
        assert not sim.armed
