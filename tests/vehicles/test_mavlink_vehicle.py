"""MavlinkVehicle against a scripted autopilot on a real UDP socket (loopback): heartbeat
loss and return, the failsafe check, foreign and malformed messages, bad connection
strings. Time is the test's: ``service(now)`` with made-up clocks, the sockets are real."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from pymavlink import mavutil
from tests.vehicles.helpers import free_port

from actorswarm.runtime.context import Vehicle
from actorswarm.vehicles.mavlink import MavlinkError
from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.link import MessageFilter, open_connection
from actorswarm.vehicles.mavlink.vehicle import (
    LINK_LOST,
    LINK_RESTORED,
    Fence,
    MavlinkSettings,
    MavlinkVehicle,
)

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)


class Autopilot:
    """The autopilot's end of the link: a pymavlink endpoint the test speaks through."""

    def __init__(
        self, port: int, system: int = 1, autopilot: int = mav.MAV_AUTOPILOT_ARDUPILOTMEGA
    ):
        self.conn = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=system, source_component=1
        )
        self.autopilot = autopilot
        self.received: list[Any] = []

    def heartbeat(self, *, armed: bool = False) -> None:
        base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if armed:
            base |= mav.MAV_MODE_FLAG_SAFETY_ARMED
        self.conn.mav.heartbeat_send(
            mav.MAV_TYPE_QUADROTOR, self.autopilot, base, 4, mav.MAV_STATE_STANDBY
        )

    def read(self) -> list[Any]:
        out = []
        while (m := self.conn.recv_match(blocking=False)) is not None:
            out.append(m)
        self.received += out
        return out

    def close(self) -> None:
        self.conn.close()


@pytest.fixture
def port() -> int:
    return free_port()


@pytest.fixture
def pilot(port: int) -> Iterator[Autopilot]:
    a = Autopilot(port)
    yield a
    a.close()


def make(port: int, **kw: Any) -> MavlinkVehicle:
    return MavlinkVehicle(
        MavlinkSettings(f"udpout:127.0.0.1:{port}", ORIGIN, name="platform 3", **kw),
        clock=lambda: 0.0,
    )


def until(condition: Callable[[], bool], step: Callable[[], None]) -> None:
    """Run ``step`` until ``condition`` holds; two seconds at most (loopback takes far less)."""
    end = time.monotonic() + 2.0
    while not condition():
        assert time.monotonic() < end, "the condition never held"
        step()
        time.sleep(0.005)


def connect(vehicle: MavlinkVehicle, pilot: Autopilot, now: float = 0.0) -> None:
    """Our first heartbeat teaches the autopilot's udpin end where we are; then it answers."""
    vehicle.service(now)
    until(lambda: bool(pilot.read()), lambda: None)
    pilot.heartbeat()
    until(lambda: vehicle.status()["link"] == "up", lambda: vehicle.service(now))


def test_is_a_vehicle_and_reads_never_block(port: int, pilot: Autopilot) -> None:
    vehicle = make(port)
    try:
        assert isinstance(vehicle, Vehicle)
        assert vehicle.position() == (0.0, 0.0, 0.0) and not vehicle.located
        assert vehicle.battery() == 1.0
        connect(vehicle, pilot)
        lat, lon, alt = ORIGIN.to_geodetic(10.0, -20.0, 5.0)
        pilot.conn.mav.global_position_int_send(
            1000, round(lat * 1e7), round(lon * 1e7), round(alt * 1000), 5000, 200, -300, 100, 0
        )
        pilot.conn.mav.sys_status_send(0, 0, 0, 500, 12000, 100, 42, 0, 0, 0, 0, 0, 0)
        until(lambda: vehicle.battery() == 0.42, lambda: vehicle.service(0.1))
        assert vehicle.status()["battery"] == 0.42
        assert vehicle.located
        assert vehicle.position() == pytest.approx((10.0, -20.0, 5.0), abs=0.01)
        # NED cm/s (north 2, east -3, down 1) -> ENU m/s
        assert vehicle.velocity() == pytest.approx((-3.0 / 1, 2.0, -1.0))
        assert vehicle.status()["autopilot"] == "ardupilot"
        assert vehicle.status()["mode"] == "GUIDED"
        # stream rates were asked for with SET_MESSAGE_INTERVAL
        asked = {
            int(m.param1)
            for m in pilot.read() + pilot.received
            if m.get_type() == "COMMAND_LONG" and m.command == mav.MAV_CMD_SET_MESSAGE_INTERVAL
        }
        assert mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT in asked
    finally:
        vehicle.close()


def test_heartbeat_silence_raises_link_lost_then_restored(port: int, pilot: Autopilot) -> None:
    vehicle = make(port, link_timeout=3.0)
    try:
        connect(vehicle, pilot, now=0.0)
        vehicle.service(2.9)
        assert vehicle.drain_events() == []
        vehicle.service(3.2)
        assert vehicle.drain_events() == [LINK_LOST]
        assert vehicle.status()["link"] == "lost"
        errors = vehicle.drain_errors()
        assert any("platform 3: no HEARTBEAT from system 1" in e for e in errors)
        vehicle.service(10.0)
        assert vehicle.drain_events() == []  # raised once, not at every look
        pilot.heartbeat()
        until(lambda: vehicle.status()["link"] == "up", lambda: vehicle.service(11.0))
        assert vehicle.drain_events() == [LINK_RESTORED]
    finally:
        vehicle.close()


def test_wrong_system_id_is_never_heard(port: int, pilot: Autopilot) -> None:
    vehicle = make(port, system=9, link_timeout=1.0, arm_timeout=4.0)
    try:
        vehicle.service(0.0)
        until(lambda: bool(pilot.read()), lambda: None)
        pilot.heartbeat()  # system 1, not 9
        until(
            lambda: vehicle.status()["dropped"].get("other system", 0) > 0,
            lambda: vehicle.service(0.5),
        )
        vehicle.takeoff(5.0)
        # It waits for system 9, as for an autopilot that boots late; the script hears of
        # the silence as vehicle_link_lost, and the log says which system was heard.
        assert vehicle.drain_errors() == []
        assert vehicle.status()["plan"] == "takeoff"
        vehicle.service(1.5)
        assert vehicle.drain_events() == [LINK_LOST]
        error = vehicle.drain_errors()[0]
        assert "no HEARTBEAT from system 9" in error
        assert error.endswith("(heard system 1 instead: a wrong --mavlink-sysid?)"), error
        assert vehicle.drain_faults() == []
        # Not heard within arm_timeout (here 4 s): the take-off fails for good.
        vehicle.service(4.5)
        why = (
            "vehicle platform 3: takeoff: the autopilot was not heard within 4 s "
            f"(no HEARTBEAT on udpout:127.0.0.1:{port})"
        )
        assert vehicle.drain_faults() == [why]
        assert why in vehicle.drain_errors()
        assert vehicle.status()["plan"] is None
    finally:
        vehicle.close()


def test_commands_asked_again_while_none_is_heard_fail_at_arm_timeout_from_the_first(
    port: int,
) -> None:
    """A plugin asking every step (a moving goal) does not put off the fault for ever."""
    clock = [0.0]
    vehicle = MavlinkVehicle(
        MavlinkSettings(f"udpout:127.0.0.1:{port}", ORIGIN, name="platform 3", arm_timeout=4.0),
        clock=lambda: clock[0],
    )
    try:
        faults = []
        for step in range(1, 13):
            clock[0] = step * 0.5
            if not faults:
                vehicle.goto(10.0, 0.0, 5.0)
            vehicle.service(clock[0])
            faults += [(clock[0], f) for f in vehicle.drain_faults()]
        # 4 s after the first goto (at 0.5 s), not after the last; once.
        assert [at for at, _ in faults] == [4.5], faults
        assert vehicle.status()["plan"] is None
    finally:
        vehicle.close()


def test_malformed_and_foreign_messages_are_counted_not_fatal(port: int, pilot: Autopilot) -> None:
    vehicle = make(port)
    try:
        connect(vehicle, pilot)
        # Bytes through the autopilot's socket: a second system's heartbeat on the same
        # link, a gimbal beside our autopilot, then a broken frame.
        foreign = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_QUADROTOR, 3, 0, 0, 0, 3)
        pilot.conn.write(foreign.pack(mav.MAVLink(None, srcSystem=2, srcComponent=1)))
        gimbal = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GIMBAL, 8, 0, 0, 0, 3)
        pilot.conn.write(gimbal.pack(mav.MAVLink(None, srcSystem=1, srcComponent=154)))
        pilot.conn.write(b"\xfd\x09garbage that is not MAVLink" * 3)
        until(
            lambda: (
                {"malformed", "other system", "other component"} <= set(vehicle.status()["dropped"])
            ),
            lambda: vehicle.service(0.1),
        )
        assert vehicle.status()["link"] == "up" and vehicle.status()["system"] == 1

        def beat() -> None:
            pilot.heartbeat(armed=True)
            vehicle.service(0.2)

        # The link reads what follows (the parser may swallow the frame right after the
        # garbage while it resynchronises: the next heartbeats get through).
        until(lambda: vehicle.armed, beat)
    finally:
        vehicle.close()


@pytest.mark.parametrize("force", [False, True])
def test_failsafes_off_refuse_the_takeoff_unless_forced(
    port: int, pilot: Autopilot, force: bool
) -> None:
    vehicle = make(port, force=force, deadline=1.0)
    try:
        connect(vehicle, pilot)

        gcs = [0.0]  # FS_GCS_ENABLE on the autopilot

        def answer_params(now: float = 0.2) -> None:
            for m in pilot.read():
                if m.get_type() == "PARAM_REQUEST_READ":
                    value = {"FS_GCS_ENABLE": gcs[0], "SYSID_MYGCS": 245.0}.get(m.param_id, 1.0)
                    pilot.conn.mav.param_value_send(m.param_id.encode(), value, 9, 500, 0)
            vehicle.service(now)

        until(lambda: vehicle.failsafes() is not None, answer_params)
        vehicle.takeoff(5.0)
        vehicle.service(0.3)
        assert vehicle.status()["starting"]  # heard at 0: the take-off waits 3 s
        pilot.received.clear()
        pilot.heartbeat()  # still there
        until(lambda: vehicle.status()["link"] == "up", lambda: vehicle.service(3.4))
        vehicle.service(3.4)  # past the start-up: planned, the parameters asked again
        until(lambda: vehicle.failsafes() is not None, lambda: answer_params(3.5))
        until(lambda: bool(pilot.read()), lambda: vehicle.service(4.6))  # our next heartbeat
        commands = [m.command for m in pilot.received if m.get_type() == "COMMAND_LONG"]
        # (this autopilot never acknowledges the stream rates: that fails on its own)
        errors = [e for e in vehicle.drain_errors() if "stream rates" not in e]
        if force:
            assert errors == []
            assert mav.MAV_CMD_DO_SET_MODE in commands  # on its way to arming
        else:
            assert mav.MAV_CMD_COMPONENT_ARM_DISARM not in commands
            assert mav.MAV_CMD_DO_SET_MODE not in commands
            assert errors == [
                "vehicle platform 3: takeoff: the failsafe parameters: FS_GCS_ENABLE is 0 "
                "(link-loss failsafe off): refusing to arm; set it on the autopilot, or "
                "force the take-off"
            ]
            # Set on the autopilot now: the next take-off reads it again and goes on.
            gcs[0] = 1.0
            pilot.received.clear()
            vehicle.takeoff(5.0)
            until(lambda: vehicle.failsafes() is True, lambda: answer_params(4.7))
            until(
                lambda: any(
                    m.get_type() == "COMMAND_LONG" and m.command == mav.MAV_CMD_DO_SET_MODE
                    for m in pilot.received
                ),
                lambda: answer_params(4.8),
            )
    finally:
        vehicle.close()


def test_goals_are_bounded_by_the_fence(port: int, pilot: Autopilot) -> None:
    vehicle = make(port, fence=Fence(-50, -50, 50, 50, 30))
    try:
        connect(vehicle, pilot)
        vehicle.goto(80.0, 0.0, 60.0)
        errors = vehicle.drain_errors()
        assert "goto (80, 0, 60) is outside the fence: flying to (50, 0, 30) instead" in errors[0]
        with pytest.raises(ValueError, match="finite"):
            vehicle.goto(float("nan"), 0.0, 1.0)
        with pytest.raises(ValueError, match="speed"):
            vehicle.goto(1.0, 0.0, 1.0, speed=-2)
        with pytest.raises(ValueError, match="altitude"):
            vehicle.takeoff(0)
    finally:
        vehicle.close()


@pytest.mark.parametrize(
    ("url", "why"),
    [
        ("flight.tlog", "write udpin:HOST:PORT"),
        ("udpout:no-such-host.invalid:14550", "no-such-host"),
        ("/dev/ttyNOPE0,57600", "ttyNOPE0"),
        ("udpin:127.0.0.1:notaport", "notaport"),
    ],
)
def test_unopenable_connection_is_a_clear_error(url: str, why: str) -> None:
    with pytest.raises(MavlinkError) as info:
        open_connection(url, who="vehicle platform 3", source_system=245, source_component=191)
    assert str(info.value).startswith(f"vehicle platform 3: cannot open MAVLink connection {url!r}")
    assert why in str(info.value)
    with pytest.raises(MavlinkError, match=r"system ID must be 1\.\.255"):
        open_connection("udpin:127.0.0.1:0", who="v", source_system=0, source_component=1)


def test_filter_adopts_the_first_autopilot() -> None:
    link = MessageFilter(None)
    codec = mav.MAVLink(None, srcSystem=4, srcComponent=1)
    status = mav.MAVLink_sys_status_message(0, 0, 0, 0, 0, 0, 50, 0, 0, 0, 0, 0, 0)
    status.pack(codec)
    assert not link.accept(status)  # not yet an autopilot heard
    beat = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_PX4, 0, 0, 0, 3)
    beat.pack(codec)
    assert link.accept(beat) and link.system == 4
    assert link.accept(status)
