"""The simulated ArduPlane flies and links as the measured ArduPlane 4.5.7 SITL does.

The figures were measured on the real firmware, outside these tests (``arduplane --model
plane --defaults plane.parm``, a pymavlink client on ``tcp:…:5760``; docs/vehicles.md), and
are written here a second time on purpose, apart from
:mod:`actorswarm.vehicles.mavlink.simplane`: a change that makes the stand-in agree with
the daemon instead of with the firmware fails here. The autopilot's clock is the test's;
the sockets are real (loopback)."""

from __future__ import annotations

import math
import socket
import time
from collections import Counter
from collections.abc import Iterator
from typing import Any

import pytest
from pymavlink import mavutil
from tests.vehicles.helpers import free_port

from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.frame import MissionFrame

HOME = MissionFrame(-35.363262, 149.165237, 584.0)

# --- ArduPlane 4.5.7 SITL, measured ---------------------------------------------------------------
#: Streams unasked from 1.9 s at 1 Hz; EKF_STATUS_REPORT from 3 s; one HOME_POSITION at 10 s,
#: one GPS_GLOBAL_ORIGIN at 21.7 s; "ArduPilot Ready" (and the first HEARTBEAT) at 1.6 s.
STREAMED_1HZ = ("ATTITUDE", "GLOBAL_POSITION_INT", "VFR_HUD", "SYS_STATUS", "GPS_RAW_INT")
STREAMS_FROM, EKF_FROM, HOME_AT, ORIGIN_AT, READY_AT = 1.9, 3.0, 10.0, 21.7, 1.6
#: The first HEARTBEAT, in mode INITIALISING (ArduPlane 4.5.7 SITL: 0.94 s after the link
#: connected, "ArduPilot Ready" and MANUAL 0.71 s later).
FIRST_HEARTBEAT = 0.9
#: Arming first accepted at 21.3 s (another boot 23.4 s).
ARMED_FROM = (21.3, 23.4)
#: TAKEOFF mode, TKOFF_ALT 40: wheels off +3.8 s after 40 m at 19.5 m/s, 39 m at +29.8 s,
#: then circles the point TKOFF_DIST (200 m) ahead at ~100 m. 20 m is first reached 6-11 s
#: after arming (10.8 s alone, 6 and 9.3 s in a flight of ten): the climb pauses while the
#: aircraft turns onto its circle, which the model does not.
WHEELS_OFF, RUN, LIFTOFF_SPEED, AT_39, TAKEOFF_CIRCLE = 3.8, 40.0, 19.5, 29.8, 100.0
AT_20 = (6.0, 11.0)
#: DO_REPOSITION, clockwise: radius flown for the param3 asked (150 is not flown here: slow).
REPOSITION_RADIUS = {0: (100.5, 100.9), 150: (174.0, 174.0), 25: (49.0, 55.0)}
#: DO_CHANGE_SPEED (airspeed): asked -> held; -2: back to cruise (21.8).
SPEEDS = {16.0: 15.9, 28.0: 28.4, -2.0: 21.8}
#: RTL: RTL_ALTITUDE 100 m, circling home at ~101 m.
RTL_ALT, RTL_RADIUS = 100.0, 101.0
#: Landing, approach waypoint 700 m out at 40 m: 3.5° at 16 m/s, touchdown 46 m short of the
#: land point, stopped 16 m short, disarmed 96 − 67.8 s after touchdown; the glide from the
#: approach waypoint to touchdown took 67.8 − 26.5 s.
GLIDE_DEG, GLIDE_SPEED, TOUCH_SHORT, STOP_SHORT = 3.5, 16.0, 46.0, 16.0
DISARM_AFTER, GLIDE_TIME = 96.0 - 67.8, 67.8 - 26.5

MODES = {
    "MANUAL": 0,
    "AUTO": 10,
    "RTL": 11,
    "LOITER": 12,
    "TAKEOFF": 13,
    "GUIDED": 15,
    "INITIALISING": 16,
}


class Station:
    """A ground station on the plane's link; the autopilot's clock moves in ``step``s."""

    def __init__(self, sim: SimAutopilot, conn: Any, clock: list[float]) -> None:
        self.sim, self.conn, self.clock = sim, conn, clock
        self.heard: list[tuple[float, Any]] = []  # (boot time received, message)

    def run(self, seconds: float, step: float = 0.05, watch: Any = None) -> Counter[str]:
        """Move the clock on by ``seconds``; what arrived meanwhile, by type. ``watch(t)``
        is called after every step with the boot time."""
        start = len(self.heard)
        end = self.clock[0] + seconds
        n = 0
        while self.clock[0] < end - 1e-9:
            self.clock[0] = min(self.clock[0] + step, end)
            self.sim.service(self.clock[0])
            n += 1
            if step < 0.5 or n % 4 == 0:
                self._drain()
            if watch is not None:
                watch(self.t)
        time.sleep(0.03)
        self._drain()
        return Counter(m.get_type() for _, m in self.heard[start:])

    @property
    def t(self) -> float:
        return self.sim.boot_time(self.clock[0])

    def _drain(self) -> None:
        while (m := self.conn.recv_match(blocking=False)) is not None:
            if m.get_type() != "BAD_DATA":
                self.heard.append((self.t, m))

    def last(self, kind: str) -> Any:
        return next(m for _, m in reversed(self.heard) if m.get_type() == kind)

    def texts(self, since: int = 0) -> list[str]:
        return [m.text for _, m in self.heard[since:] if m.get_type() == "STATUSTEXT"]

    def command(self, command: int, *params: float) -> int:
        """A COMMAND_LONG; its ACK's result."""
        p = [*params, 0, 0, 0, 0, 0, 0, 0][:7]
        self.conn.mav.command_long_send(1, 1, command, 0, *p)
        return self._ack(command)

    def command_int(
        self,
        command: int,
        frame: int,
        p: tuple[float, float, float, float],
        x: int,
        y: int,
        z: float,
    ) -> int:
        self.conn.mav.command_int_send(1, 1, frame, command, 0, 0, *p, x, y, z)
        return self._ack(command)

    def _ack(self, command: int) -> int:
        time.sleep(0.03)
        before = len(self.heard)
        self.run(0.05)
        acks = [m for _, m in self.heard[before:] if m.get_type() == "COMMAND_ACK"]
        assert acks and acks[-1].command == command, f"no ACK for {command}"
        return int(acks[-1].result)

    def set_mode(self, name: str) -> int:
        return self.command(mav.MAV_CMD_DO_SET_MODE, 1, MODES[name])

    def set_param(self, name: str, value: float) -> None:
        self.conn.mav.param_set_send(1, 1, name.encode(), value, mav.MAV_PARAM_TYPE_REAL32)
        time.sleep(0.03)
        self.run(0.05)
        echo = self.last("PARAM_VALUE")
        assert echo.param_id == name and echo.param_value == pytest.approx(value)

    def upload(self, items: list[Any], mission_type: int = 0) -> Any:
        """The mission protocol, as a ground station drives it; the MISSION_ACK."""
        self.conn.mav.mission_count_send(1, 1, len(items), mission_type)
        for _ in range(len(items) + 1):
            time.sleep(0.03)
            before = len(self.heard)
            self.run(0.05)
            got = [m for _, m in self.heard[before:] if m.get_type().startswith("MISSION_")]
            assert got, "no answer to the mission upload"
            if got[-1].get_type() == "MISSION_ACK":
                return got[-1]
            self.conn.mav.send(items[got[-1].seq])
        raise AssertionError("the upload did not end")


def item(seq: int, command: int, north: float = 0.0, alt: float = 0.0) -> Any:
    lat, lon, _ = HOME.to_geodetic(0.0, north, 0.0)
    return mav.MAVLink_mission_item_int_message(
        1, 1, seq, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, 0, 1, 0, 0, 0, 0,
        round(lat * 1e7), round(lon * 1e7), alt, 0,
    )  # fmt: skip


def open_plane(ready_after: float | None = None) -> tuple[Station, SimAutopilot, Any]:
    port = free_port(socket.SOCK_STREAM)
    clock = [1000.0]
    sim = SimAutopilot(
        AutopilotOptions(f"tcpin:127.0.0.1:{port}", HOME, frame="plane", ready_after=ready_after),
        clock=lambda: clock[0],
    )
    conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=255)
    for _ in range(100):  # the autopilot takes the client: its clock starts
        sim.service(clock[0])
        if sim.boot_time(clock[0] + 1.0) > 0:
            break
        time.sleep(0.01)
    return Station(sim, conn, clock), sim, conn


@pytest.fixture
def plane() -> Iterator[Station]:
    """ArduPlane's SERIAL0 as SITL has it, the measured boot (22 s to arming)."""
    station, sim, conn = open_plane()
    try:
        yield station
    finally:
        conn.close()
        sim.close()


@pytest.fixture
def quick() -> Iterator[Station]:
    """The same with a 1 s boot (its steps scaled), for the flight tests."""
    station, sim, conn = open_plane(ready_after=1.0)
    try:
        station.run(1.2, step=0.1)
        yield station
    finally:
        conn.close()
        sim.close()


def take_off(s: Station, alt: float = 40.0) -> None:
    s.set_param("TKOFF_ALT", alt)
    assert s.set_mode("TAKEOFF") == mav.MAV_RESULT_ACCEPTED
    assert s.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED


def circle(s: Station, seconds: float, centre: tuple[float, float]) -> tuple[float, float, bool]:
    """Fly ``seconds``; the least and greatest distance from ``centre`` and whether it
    went round clockwise."""
    radii: list[float] = []
    turn = [0.0]
    last = [None]

    def watch(_: float) -> None:
        x, y, _z = s.sim.position()
        radii.append(math.hypot(x - centre[0], y - centre[1]))
        angle = math.atan2(y - centre[1], x - centre[0])
        if last[0] is not None:
            turn[0] += math.remainder(angle - last[0], math.tau)
        last[0] = angle

    s.run(seconds, step=0.5, watch=watch)
    return min(radii), max(radii), turn[0] < 0


# --- the link -------------------------------------------------------------------------------------


def test_streams_unasked_at_1_hz_from_its_boot(plane: Station) -> None:
    counts = plane.run(25.0, step=0.05)
    first = {}
    for t, m in plane.heard:
        first.setdefault(m.get_type(), t)
    beat = plane.last("HEARTBEAT")
    assert (beat.type, beat.autopilot) == (mav.MAV_TYPE_FIXED_WING, mav.MAV_AUTOPILOT_ARDUPILOTMEGA)
    assert beat.custom_mode == MODES["MANUAL"]
    assert first["HEARTBEAT"] == pytest.approx(FIRST_HEARTBEAT, abs=0.15)
    modes = [m.custom_mode for t, m in plane.heard if m.get_type() == "HEARTBEAT" and t < READY_AT]
    assert set(modes) == {MODES["INITIALISING"]}, modes
    for name in STREAMED_1HZ:
        assert first[name] == pytest.approx(STREAMS_FROM, abs=0.15), name
        assert abs(counts[name] - (25.0 - STREAMS_FROM)) <= 1.5, f"{name}: {counts[name]}"
    assert first["EKF_STATUS_REPORT"] == pytest.approx(EKF_FROM, abs=0.15)
    assert counts["HOME_POSITION"] == counts["GPS_GLOBAL_ORIGIN"] == 1
    assert first["HOME_POSITION"] == pytest.approx(HOME_AT, abs=0.15)
    assert first["GPS_GLOBAL_ORIGIN"] == pytest.approx(ORIGIN_AT, abs=0.15)


def test_an_interval_asked_before_the_first_heartbeat_is_acked_and_never_applied(
    plane: Station,
) -> None:
    plane.run(0.5)
    ask = (mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_SYS_STATUS, 200_000)
    assert plane.command(*ask) == mav.MAV_RESULT_ACCEPTED
    assert plane.run(5.0, step=0.1)["SYS_STATUS"] <= 6  # still 1 Hz
    assert plane.command(*ask) == mav.MAV_RESULT_ACCEPTED
    plane.run(1.0, step=0.05)  # applied within 1 s
    assert plane.run(4.0, step=0.05)["SYS_STATUS"] >= 18  # 5 Hz


def test_a_mission_before_ardupilot_ready_is_refused(plane: Station) -> None:
    plane.run(0.5)
    ack = plane.upload([item(0, mav.MAV_CMD_NAV_WAYPOINT)])
    assert ack.type == mav.MAV_MISSION_NO_SPACE
    assert any("Only 0 items" in text for text in plane.texts())
    plane.run(READY_AT, step=0.1)
    assert plane.upload([item(0, mav.MAV_CMD_NAV_WAYPOINT)]).type == mav.MAV_MISSION_ACCEPTED


def test_a_mode_asked_while_initialising_is_accepted_then_lost_at_ready(plane: Station) -> None:
    """As ArduPlane 4.5.7 SITL did: DO_SET_MODE TAKEOFF at its first HEARTBEAT ACCEPTED and
    shown, then MANUAL at "ArduPilot Ready" (an aircraft armed after that stays put)."""
    plane.run(FIRST_HEARTBEAT + 0.1)
    assert plane.last("HEARTBEAT").custom_mode == MODES["INITIALISING"]
    assert plane.command(mav.MAV_CMD_DO_SET_MODE, 1, MODES["TAKEOFF"]) == mav.MAV_RESULT_ACCEPTED
    plane.run(0.3)
    assert plane.sim.mode_name == "TAKEOFF"
    plane.run(READY_AT + 0.5 - plane.t)
    assert plane.sim.mode_name == "MANUAL"
    assert plane.last("HEARTBEAT").custom_mode == MODES["MANUAL"]
    # Asked again after Ready, it stays.
    assert plane.command(mav.MAV_CMD_DO_SET_MODE, 1, MODES["TAKEOFF"]) == mav.MAV_RESULT_ACCEPTED
    plane.run(2.0)
    assert plane.last("HEARTBEAT").custom_mode == MODES["TAKEOFF"]


def test_arming_is_refused_with_its_reasons_until_about_22_s(plane: Station) -> None:
    plane.run(0.1)
    assert plane.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    said = plane.texts()
    for reason in (
        "Accels inconsistent",
        "Compass not healthy",
        "AHRS: waiting for home",
        "Airspeed 1 not healthy",
        "INITIALISING mode not armable",
    ):
        assert f"Arm: {reason}" in said, reason
    plane.run(14.0 - plane.t, step=0.5)
    mark = len(plane.heard)
    assert plane.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    assert plane.texts(mark) == ["Arm: Gyros inconsistent"]
    plane.run(ARMED_FROM[0] - 0.5 - plane.t, step=0.5)
    assert plane.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    plane.run(ARMED_FROM[1] - plane.t, step=0.5)
    assert plane.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert plane.sim.armed and plane.sim.physics_mode == "ground"  # MANUAL: it stays put


# --- flying ---------------------------------------------------------------------------------------


def test_takeoff_mode_rolls_lifts_off_climbs_and_circles_ahead(quick: Station) -> None:
    take_off(quick)
    start = quick.t
    seen: dict[str, tuple[float, float, float]] = {}

    def watch(t: float) -> None:
        _, y, z = quick.sim.position()
        for name, reached in (("off", z > 0), ("20", z >= 20), ("39", z >= 39)):
            if reached and name not in seen:
                seen[name] = (t - start, y, quick.sim._vehicle.speed())

    quick.run(35.0, step=0.02, watch=watch)
    assert seen["off"][0] == pytest.approx(WHEELS_OFF, abs=0.3)
    assert seen["off"][1] == pytest.approx(RUN, abs=5.0)
    assert seen["off"][2] == pytest.approx(LIFTOFF_SPEED, abs=0.5)
    assert AT_20[0] <= seen["20"][0] <= AT_20[1]
    # Up to 2 s early: the model climbs on through the turn where the firmware pauses.
    assert seen["39"][0] == pytest.approx(AT_39, abs=2.5)
    low, high, clockwise = circle(quick, 60.0, (0.0, 200.0))  # TKOFF_DIST north
    assert high - low < 3 and low == pytest.approx(TAKEOFF_CIRCLE, abs=5.0) and clockwise
    assert quick.sim.mode_name == "TAKEOFF" and quick.sim.position()[2] == pytest.approx(40, abs=1)


def reposition(s: Station, east: float, north: float, radius: float, change: bool) -> int:
    lat, lon, _ = HOME.to_geodetic(east, north, 0.0)
    flags = mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE if change else 0
    return s.command_int(
        mav.MAV_CMD_DO_REPOSITION,
        mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        (-1, flags, radius, 0),
        round(lat * 1e7),
        round(lon * 1e7),
        60.0,
    )


def test_guided_repositions_circle_clockwise_wider_than_asked(quick: Station) -> None:
    take_off(quick)
    quick.run(30.0, step=0.5)
    assert quick.set_mode("LOITER") == mav.MAV_RESULT_ACCEPTED
    assert reposition(quick, 800, 0, 0, change=False) == mav.MAV_RESULT_FAILED  # not GUIDED
    for asked in (0, 25):
        assert reposition(quick, 800, 0, asked, change=True) == mav.MAV_RESULT_ACCEPTED
        assert quick.sim.mode_name == "GUIDED"
        quick.run(50.0, step=0.5)
        low, high, clockwise = circle(quick, 30.0, (800.0, 0.0))
        want_low, want_high = REPOSITION_RADIUS[asked]
        assert want_low - 2 <= low <= high <= want_high + 2, (asked, low, high)
        assert clockwise
    assert quick.sim.position()[2] == pytest.approx(60.0, abs=1.0)
    # SET_POSITION_TARGET_GLOBAL_INT: latitude and longitude ignored, the altitude applied.
    lat, lon, _ = HOME.to_geodetic(-2000.0, 3000.0, 0.0)
    quick.conn.mav.set_position_target_global_int_send(
        0, 1, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0b110111111000,
        round(lat * 1e7), round(lon * 1e7), 90.0, 0, 0, 0, 0, 0, 0, 0, 0,
    )  # fmt: skip
    time.sleep(0.03)
    quick.run(30.0, step=0.5)
    low, high, _ = circle(quick, 10.0, (800.0, 0.0))
    assert high < 200 and quick.sim.position()[2] == pytest.approx(90.0, abs=1.0)


def airspeed(s: Station, seconds: float = 15.0) -> float:
    s.run(seconds, step=0.5)
    return s.sim._vehicle.speed()


def test_change_speed_holds_within_limits_in_guided_and_resets_on_a_mode_change(
    quick: Station,
) -> None:
    take_off(quick)
    quick.run(20.0, step=0.5)
    change = mav.MAV_CMD_DO_CHANGE_SPEED
    assert quick.command(change, 0, 16) == mav.MAV_RESULT_FAILED  # TAKEOFF: not taken
    assert reposition(quick, 0, 600, 0, change=True) == mav.MAV_RESULT_ACCEPTED
    for asked, held in SPEEDS.items():
        assert quick.command(change, 0, asked) == mav.MAV_RESULT_ACCEPTED
        assert airspeed(quick) == pytest.approx(held, abs=0.6), asked
    assert quick.command(change, 0, 35) == mav.MAV_RESULT_FAILED  # above AIRSPEED_MAX
    assert quick.command(change, 0, 28) == mav.MAV_RESULT_ACCEPTED
    # GUIDED asked again changes nothing (ArduPlane's set_mode returns at once)...
    assert quick.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert airspeed(quick) == pytest.approx(28.0, abs=0.6)
    # ... a real mode change resets the airspeed to cruise.
    assert quick.set_mode("LOITER") == mav.MAV_RESULT_ACCEPTED
    assert airspeed(quick) == pytest.approx(SPEEDS[-2.0], abs=0.6)
    assert quick.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    guided_speed = mav.MAV_CMD_GUIDED_CHANGE_SPEED
    frame = mav.MAV_FRAME_GLOBAL
    assert quick.command_int(guided_speed, frame, (0, 18, 0, 0), 0, 0, 0) == 0
    assert airspeed(quick) == pytest.approx(18.0, abs=0.6)
    assert quick.command_int(guided_speed, frame, (0, 35, 0, 0), 0, 0, 0) == (mav.MAV_RESULT_DENIED)


def test_rtl_climbs_to_rtl_altitude_and_circles_home_for_ever(quick: Station) -> None:
    take_off(quick)
    quick.run(20.0, step=0.5)
    assert quick.set_mode("RTL") == mav.MAV_RESULT_ACCEPTED
    quick.run(75.0, step=0.5)
    low, high, clockwise = circle(quick, 30.0, (0.0, 0.0))
    assert low == pytest.approx(RTL_RADIUS, abs=3.0) and high - low < 3 and clockwise
    assert quick.sim.position()[2] == pytest.approx(RTL_ALT, abs=1.0)
    assert quick.sim.armed and quick.sim.mode_name == "RTL"


def test_landing_commands_without_a_mission(quick: Station) -> None:
    assert quick.command(mav.MAV_CMD_NAV_LAND) == mav.MAV_RESULT_UNSUPPORTED
    assert quick.command(mav.MAV_CMD_DO_LAND_START) == mav.MAV_RESULT_FAILED
    assert quick.command(mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 40) == mav.MAV_RESULT_FAILED
    assert quick.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    assert quick.command(mav.MAV_CMD_DO_SET_MODE, 1, 99) == mav.MAV_RESULT_FAILED


LANDING = [
    item(0, mav.MAV_CMD_NAV_WAYPOINT),
    item(1, mav.MAV_CMD_DO_LAND_START),
    item(2, mav.MAV_CMD_NAV_WAYPOINT, north=700.0, alt=40.0),
    item(3, mav.MAV_CMD_NAV_LAND),
]


def test_a_landing_sequence_glides_touches_down_short_and_disarms(quick: Station) -> None:
    assert quick.upload(LANDING).type == mav.MAV_MISSION_ACCEPTED
    quick.set_param("TKOFF_ALT", 40.0)
    assert quick.set_mode("TAKEOFF") == mav.MAV_RESULT_ACCEPTED
    mark = len(quick.heard)
    assert quick.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    assert "Arm: DO_LAND_START set and RTL_AUTOLAND disabled" in quick.texts(mark)
    quick.set_param("RTL_AUTOLAND", 1.0)
    assert quick.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    quick.run(40.0, step=0.5)
    assert quick.command(mav.MAV_CMD_DO_LAND_START) == mav.MAV_RESULT_ACCEPTED
    assert quick.sim.mode_name == "AUTO"
    track: list[tuple[float, float, float, float, float]] = []

    def watch(t: float) -> None:
        x, y, z = quick.sim.position()
        track.append((t, x, y, z, quick.sim._vehicle.speed()))

    quick.run(150.0, step=0.1, watch=watch)
    descent = [p for p in track if 1.0 < p[3] < 35.0]
    (_, x0, y0, z0, _), (_, x1, y1, z1, s1) = descent[0], descent[-1]
    angle = math.degrees(math.atan2(z0 - z1, math.hypot(x1 - x0, y1 - y0)))
    assert angle == pytest.approx(GLIDE_DEG, abs=0.3) and s1 == pytest.approx(GLIDE_SPEED, abs=0.5)
    touch = next(p for p in track if p[3] <= 0.0)
    assert touch[2] == pytest.approx(TOUCH_SHORT, abs=15.0)  # short of the land point (home)
    assert 0 < track[-1][2] == pytest.approx(STOP_SHORT, abs=8.0)
    began = next(p for p in track if p[3] < 39.5 and math.hypot(p[1], p[2]) < 700)
    assert touch[0] - began[0] == pytest.approx(GLIDE_TIME, abs=3.0)
    disarmed = next(t for t, m in quick.heard if m.get_type() == "HEARTBEAT" and t > touch[0]
                    and not m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)  # fmt: skip
    assert disarmed - touch[0] == pytest.approx(DISARM_AFTER, abs=1.5)
    assert not quick.sim.armed and quick.sim.physics_mode == "landed"


def test_the_fence_still_goes_to_the_fence(quick: Station) -> None:
    fence = [
        mav.MAVLink_mission_item_int_message(
            1, 1, seq, mav.MAV_FRAME_GLOBAL, mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            0, 1, 3, 0, 0, 0, round(HOME.lat * 1e7) + seq * 1000, round(HOME.lon * 1e7),
            0, mav.MAV_MISSION_TYPE_FENCE,
        )
        for seq in range(3)
    ]  # fmt: skip
    assert quick.upload(fence, mav.MAV_MISSION_TYPE_FENCE).type == mav.MAV_MISSION_ACCEPTED
    assert len(quick.sim.fence.polygon()) == 3
    assert quick.sim.fence.items and not quick.sim._plane.mission  # type: ignore[union-attr]
