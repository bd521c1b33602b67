"""The fixed-wing parts of the MAVLink vehicle, without a link: the goal and speed stream
(:class:`PlaneGuidance`), the mission write (:class:`MissionWrite`), the landing mission's
geometry and ArduPlane's mode names."""

from __future__ import annotations

import itertools
import math
from typing import Any

import pytest

from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.fixedwing import (
    APPROACH_DISTANCE,
    APPROACH_HEIGHT,
    LOITER_RADIUS,
    PlaneGuidance,
    landing_items,
)
from actorswarm.vehicles.mavlink.flavours import Target, mode_name
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.mission import MissionWrite

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)


def _target(goal: tuple[float, float, float], speed: float | None = None) -> Target:
    return Target(goal, goal, speed, 2.0)


def _kinds(messages: list[Any]) -> list[str]:
    out = []
    for m in messages:
        if m.get_type() == "COMMAND_INT" and m.command == mav.MAV_CMD_DO_REPOSITION:
            out.append("reposition")
        elif m.get_type() == "COMMAND_LONG" and m.command == mav.MAV_CMD_DO_CHANGE_SPEED:
            out.append(f"speed {m.param2:g}")
        else:
            out.append(m.get_type())
    return out


def test_a_goal_goes_out_as_a_reposition_in_absolute_altitude_with_the_tight_radius() -> None:
    g = PlaneGuidance(ORIGIN, 3, 1)
    (m,) = g.messages(_target((100.0, 50.0, 60.0)), "GUIDED", 0.0)
    assert m.get_type() == "COMMAND_INT" and m.command == mav.MAV_CMD_DO_REPOSITION
    assert (m.target_system, m.target_component) == (3, 1)
    assert m.frame == mav.MAV_FRAME_GLOBAL_INT
    assert m.param3 == LOITER_RADIUS and m.param1 == -1
    assert int(m.param2) & mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
    lat, lon, alt = ORIGIN.to_geodetic(100.0, 50.0, 60.0)
    assert (m.x, m.y) == (round(lat * 1e7), round(lon * 1e7))
    assert m.z == pytest.approx(alt)


def test_a_moving_goal_is_sent_at_most_twice_a_second_and_a_still_one_repaired() -> None:
    g = PlaneGuidance(ORIGIN, 1, 1)
    sent = []
    for step in range(100):  # 10 s at 10 Hz, the goal moving 1.6 m per step for 5 s
        t = step * 0.1
        x = 16.0 * min(t, 5.0)
        sent += [t for m in g.messages(_target((x, 0.0, 60.0)), "GUIDED", t) if m]
    moving = [t for t in sent if t < 5.0]
    still = [t for t in sent if t > 5.05]
    assert len(moving) == 10  # 2 Hz over 5 s
    assert all(b - a >= 0.5 - 1e-9 for a, b in itertools.pairwise(moving))
    assert len(still) == 2  # the last move went out at 5.0 s; repaired at 7 and 9 s


def test_the_speed_goes_out_on_a_change_once_a_second_and_again_after_a_mode_change() -> None:
    g = PlaneGuidance(ORIGIN, 1, 1)
    goal = (0.0, 0.0, 60.0)

    def speeds(speed: float | None, mode: str, t: float) -> list[str]:
        return [k for k in _kinds(g.messages(_target(goal, speed), mode, t)) if k != "reposition"]

    assert speeds(18.0, "GUIDED", 0.0) == ["speed 18"]
    assert speeds(18.2, "GUIDED", 0.3) == []  # under SPEED_STEP
    assert speeds(20.0, "GUIDED", 0.6) == []  # under a second since the last
    assert speeds(20.0, "GUIDED", 1.0) == ["speed 20"]
    # ArduPlane resets its airspeed at every mode change, and takes one only in GUIDED/AUTO.
    assert speeds(20.0, "LOITER", 2.1) == []
    assert speeds(20.0, "GUIDED", 2.2) == ["speed 20"]
    # Unchanged: repaired every SPEED_REPAIR seconds.
    assert speeds(20.0, "GUIDED", 6.0) == []
    assert speeds(20.0, "GUIDED", 7.3) == ["speed 20"]
    # No speed asked: back to cruise (-2), sent because another one was set.
    assert speeds(None, "GUIDED", 8.4) == ["speed -2"]


def test_a_speed_outside_the_autopilots_airspeed_limits_is_clamped_to_them() -> None:
    g = PlaneGuidance(ORIGIN, 1, 1, low=10.0, high=30.0)
    (speed,) = g.messages(_target((0.0, 0.0, 60.0), 38.0), "GUIDED", 0.0)[1:]
    assert speed.param2 == 30.0
    (speed,) = g.messages(_target((0.0, 0.0, 60.0), 4.0), "GUIDED", 1.0)
    assert speed.param2 == 10.0


def test_no_speed_asked_after_a_mode_change_sends_none() -> None:
    g = PlaneGuidance(ORIGIN, 1, 1)
    assert _kinds(g.messages(_target((0.0, 0.0, 60.0)), "GUIDED", 0.0)) == ["reposition"]


def test_no_target_sends_nothing_and_the_next_goal_goes_out_at_once() -> None:
    g = PlaneGuidance(ORIGIN, 1, 1)
    g.messages(_target((0.0, 0.0, 60.0)), "GUIDED", 0.0)
    assert g.messages(None, "LOITER", 0.1) == []
    assert _kinds(g.messages(_target((0.0, 0.0, 60.0)), "GUIDED", 0.6)) == ["reposition"]


def test_the_landing_comes_back_along_the_take_off_run_to_home() -> None:
    items = landing_items(ORIGIN, (4, 1), (10.0, 20.0, 0.0), (0.0, 1.0))
    commands = [m.command for m in items]
    assert commands == [
        mav.MAV_CMD_NAV_WAYPOINT,
        mav.MAV_CMD_DO_LAND_START,
        mav.MAV_CMD_NAV_WAYPOINT,
        mav.MAV_CMD_NAV_LAND,
    ]
    assert [m.seq for m in items] == [0, 1, 2, 3]
    assert all(m.mission_type == mav.MAV_MISSION_TYPE_MISSION for m in items)
    approach, land = items[2], items[3]
    x, y, _ = ORIGIN.to_local(approach.x / 1e7, approach.y / 1e7, ORIGIN.alt)
    assert (x, y) == (pytest.approx(10.0, abs=0.05), pytest.approx(20.0 - APPROACH_DISTANCE, 0.01))
    assert approach.z == APPROACH_HEIGHT and land.z == 0.0
    x, y, _ = ORIGIN.to_local(land.x / 1e7, land.y / 1e7, ORIGIN.alt)
    assert math.dist((x, y), (10.0, 20.0)) < 0.05


class _Autopilot:
    """The autopilot's side of a mission write, as ArduPilot answers it."""

    def __init__(self, refuse: int | None = None) -> None:
        self.items: list[Any] = []
        self.refuse = refuse
        self.expected = 0

    def answer(self, message: Any) -> list[Any]:
        kind = message.get_type()
        if kind == "MISSION_CLEAR_ALL":
            self.items = []
            return [mav.MAVLink_mission_ack_message(245, 191, mav.MAV_MISSION_ACCEPTED, 0)]
        if kind == "MISSION_COUNT":
            if self.refuse is not None:
                return [mav.MAVLink_mission_ack_message(245, 191, self.refuse, 0)]
            self.expected, self.items = message.count, []
            return [mav.MAVLink_mission_request_int_message(245, 191, 0, 0)]
        if kind == "MISSION_ITEM_INT":
            self.items.append(message)
            if len(self.items) < self.expected:
                return [mav.MAVLink_mission_request_int_message(245, 191, len(self.items), 0)]
            return [mav.MAVLink_mission_ack_message(245, 191, mav.MAV_MISSION_ACCEPTED, 0)]
        return []


def _run(write: MissionWrite, autopilot: _Autopilot, *, lose_first: bool = False) -> float:
    outbox = write.start(0.0)
    if lose_first:
        outbox = []
    t = 0.0
    while not write.done and write.error is None and t < 20.0:
        t += 0.1
        replies = [r for m in outbox for r in autopilot.answer(m)]
        outbox = [o for r in replies for o in write.on_message(r, t)] + write.tick(t)
    return t


def test_a_mission_is_written_item_by_item_as_the_autopilot_asks() -> None:
    items = landing_items(ORIGIN, (4, 1), (0.0, 0.0, 0.0), (1.0, 0.0))
    autopilot = _Autopilot()
    write = MissionWrite(items, (4, 1), what="the landing mission", who="vehicle 3")
    _run(write, autopilot, lose_first=True)  # the lost count is sent again
    assert write.done and [m.seq for m in autopilot.items] == [0, 1, 2, 3]


def test_no_items_clears_the_mission() -> None:
    autopilot = _Autopilot()
    autopilot.items = ["old"]
    write = MissionWrite([], (4, 1))
    _run(write, autopilot)
    assert write.done and autopilot.items == []


def test_a_refused_write_says_why_naming_the_vehicle() -> None:
    items = landing_items(ORIGIN, (4, 1), (0.0, 0.0, 0.0), (1.0, 0.0))
    write = MissionWrite(items, (4, 1), what="the landing mission", who="vehicle 3")
    _run(write, _Autopilot(refuse=mav.MAV_MISSION_ERROR))
    assert write.error == "vehicle 3: the autopilot refused the landing mission: MAV_MISSION_ERROR"


def test_an_autopilot_that_never_answers_fails_the_write_at_its_deadline() -> None:
    write = MissionWrite([], (4, 1), what="the mission clear", who="vehicle 3", deadline=3.0)
    write.start(0.0)
    resent = sum(len(write.tick(t / 10)) for t in range(1, 40))
    assert resent >= 4 and write.error is not None
    assert "did not take the mission clear in 3 s" in write.error


def test_arduplane_modes_are_named_by_their_own_numbers() -> None:
    assert mode_name("ardupilot", 1, 15, "plane") == "GUIDED"
    assert mode_name("ardupilot", 1, 13, "plane") == "TAKEOFF"
    assert mode_name("ardupilot", 1, 12, "plane") == "LOITER"
    assert mode_name("ardupilot", 1, 4, "plane") == "Mode(4)"
    assert mode_name("ardupilot", 1, 4) == "GUIDED"  # a copter's 4
