"""The simulated autopilot links as the measured firmware does — not as the daemon would like.

The figures below were measured on the real firmware, outside these tests (ArduCopter 4.5.7
SITL's first serial port over TCP, PX4 v1.15.4 SITL's onboard UDP link, a fresh boot, a
client that asks for nothing), and are written here on purpose a second time, apart from
:mod:`actorswarm.vehicles.mavlink.firmware`: a change to the stand-in that makes it agree
with the daemon instead of with the firmware fails here. The autopilot's clock is the
test's; the sockets are real (loopback)."""

from __future__ import annotations

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

HOME = MissionFrame(47.397742, 8.545594, 488.0)

#: ArduCopter 4.5.7, SERIAL0, the first 25 s, asking for nothing: message -> count.
ARDUCOPTER_FIRST_25_S = {"HEARTBEAT": 27, "TIMESYNC": 2, "HOME_POSITION": 1, "GPS_GLOBAL_ORIGIN": 1}
#: PX4 1.15.4 SIH, the onboard link, the first 20 s, asking for nothing: messages per second
#: (those pymavlink's ArduPilot dialect can encode).
PX4_ONBOARD_PER_S = {
    "HIGHRES_IMU": 49.7, "ODOMETRY": 29.8, "LOCAL_POSITION_NED": 29.8, "TIMESYNC": 9.9,
    "ALTITUDE": 9.9, "ATTITUDE_TARGET": 9.9, "DISTANCE_SENSOR": 9.9,
    "POSITION_TARGET_LOCAL_NED": 9.9, "SERVO_OUTPUT_RAW": 9.9, "VFR_HUD": 9.9,
    "GPS_RAW_INT": 8.0, "EXTENDED_SYS_STATE": 5.0, "SYS_STATUS": 5.0, "ESTIMATOR_STATUS": 1.0,
    "SCALED_PRESSURE": 1.0, "SYSTEM_TIME": 1.0, "PING": 1.0, "OPEN_DRONE_ID_LOCATION": 1.0,
    "OPEN_DRONE_ID_SYSTEM": 1.0, "HEARTBEAT": 0.9, "MISSION_CURRENT": 0.9,
    "BATTERY_STATUS": 0.5, "HOME_POSITION": 0.5, "VIBRATION": 0.5,
}  # fmt: skip


class Client:
    """A ground station on the autopilot's link that, unless told, asks for nothing and
    sends nothing; the autopilot's clock moves in steps of ``step`` seconds."""

    def __init__(self, sim: SimAutopilot, conn: Any, clock: list[float], step: float) -> None:
        self.sim, self.conn, self.clock, self.step = sim, conn, clock, step
        self.heard: list[Any] = []

    def run(self, seconds: float) -> Counter[str]:
        """Move the autopilot's clock on by ``seconds``; what arrived meanwhile, by type."""
        got: list[Any] = []
        end = self.clock[0] + seconds
        n = 0
        while self.clock[0] < end - 1e-9:
            self.clock[0] = min(self.clock[0] + self.step, end)
            self.sim.service(self.clock[0])
            n += 1
            if n % 20 == 0:
                got += self._drain()
        time.sleep(0.05)
        got += self._drain()
        self.heard += got
        return Counter(m.get_type() for m in got)

    def _drain(self) -> list[Any]:
        out = []
        while (m := self.conn.recv_match(blocking=False)) is not None:
            if m.get_type() != "BAD_DATA":
                out.append(m)
        return out

    def ask(self, message_id: int, interval_s: float) -> None:
        self.conn.mav.command_long_send(
            1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, message_id, interval_s * 1e6, 0, 0, 0, 0, 0
        )


@pytest.fixture
def copter() -> Iterator[Client]:
    """ArduCopter's SERIAL0 as SITL has it: TCP, the clock starting with the first client."""
    port = free_port(socket.SOCK_STREAM)
    clock = [1000.0]
    sim = SimAutopilot(
        AutopilotOptions(f"tcpin:127.0.0.1:{port}", HOME, kind="ardupilot"),
        clock=lambda: clock[0],
    )
    conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=245)
    try:
        for _ in range(100):  # the autopilot takes the client
            sim.service(clock[0])
            if sim.boot_time(clock[0] + 1.0) > 0:
                break
            time.sleep(0.01)
        yield Client(sim, conn, clock, 0.05)
    finally:
        conn.close()
        sim.close()


def test_arducopter_sends_almost_nothing_until_asked(copter: Client) -> None:
    counts = copter.run(25.0)
    assert set(counts) == set(ARDUCOPTER_FIRST_25_S), f"sent unasked: {dict(counts)}"
    assert abs(counts["HEARTBEAT"] - ARDUCOPTER_FIRST_25_S["HEARTBEAT"]) <= 3
    assert 1 <= counts["TIMESYNC"] <= 3
    assert counts["HOME_POSITION"] == counts["GPS_GLOBAL_ORIGIN"] == 1  # once, at the origin
    home = next(m for m in copter.heard if m.get_type() == "HOME_POSITION")
    assert home.latitude == round(HOME.lat * 1e7)


def test_arducopter_streams_what_a_link_asks_for_at_the_rate_asked(copter: Client) -> None:
    copter.run(1.0)
    wanted = {
        mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT: "EKF_STATUS_REPORT",
        mav.MAVLINK_MSG_ID_GPS_RAW_INT: "GPS_RAW_INT",
        mav.MAVLINK_MSG_ID_SYS_STATUS: "SYS_STATUS",
    }
    for message_id in wanted:
        copter.ask(message_id, 1.0)
    time.sleep(0.05)
    counts = copter.run(8.0)
    acks = [(int(m.command), int(m.result)) for m in copter.heard if m.get_type() == "COMMAND_ACK"]
    assert acks == [(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAV_RESULT_ACCEPTED)] * 3
    for name in wanted.values():
        assert 6 <= counts[name] <= 9, f"{name}: {counts[name]} in 8 s at 1 Hz"
    assert "GLOBAL_POSITION_INT" not in counts  # not asked, not sent
    copter.ask(9999, 1.0)  # a message it has none of
    time.sleep(0.05)
    copter.run(0.5)
    last = [m for m in copter.heard if m.get_type() == "COMMAND_ACK"][-1]
    assert last.result == mav.MAV_RESULT_DENIED  # ArduCopter 4.5.7's answer


def test_arducopter_takes_the_legacy_stream_request(copter: Client) -> None:
    copter.run(1.0)
    copter.conn.mav.request_data_stream_send(1, 1, mav.MAV_DATA_STREAM_EXTRA3, 2, 1)
    time.sleep(0.05)
    counts = copter.run(5.0)
    assert 8 <= counts["EKF_STATUS_REPORT"] <= 11  # 2 Hz, no ACK
    assert not [m for m in copter.heard if m.get_type() == "COMMAND_ACK"]


def test_arducopter_speaks_statustext_only_to_a_link_that_spoke() -> None:
    port = free_port(socket.SOCK_STREAM)
    clock = [0.0]
    sim = SimAutopilot(
        AutopilotOptions(f"tcpin:127.0.0.1:{port}", HOME, kind="ardupilot", ready_after=2.0),
        clock=lambda: clock[0],
    )
    conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=245)
    try:
        client = Client(sim, conn, clock, 0.05)
        assert "STATUSTEXT" not in client.run(1.0)  # silent client, inactive link
        conn.mav.heartbeat_send(mav.MAV_TYPE_ONBOARD_CONTROLLER, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        time.sleep(0.05)
        assert "STATUSTEXT" in client.run(1.5)  # the boot goes on talking to it
    finally:
        conn.close()
        sim.close()


def test_px4_streams_its_onboard_set_unasked_at_the_measured_rates() -> None:
    port = free_port()
    clock = [500.0]
    # PX4's onboard link sends to its remote port: the test listens there.
    conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=245)
    sim = SimAutopilot(
        AutopilotOptions(f"udpout:127.0.0.1:{port}", HOME, kind="px4"), clock=lambda: clock[0]
    )
    try:
        counts = Client(sim, conn, clock, 0.01).run(20.0)
        assert set(counts) == set(PX4_ONBOARD_PER_S), f"differs: {dict(counts)}"
        for name, rate in PX4_ONBOARD_PER_S.items():
            measured = counts[name] / 20.0
            assert abs(measured - rate) <= max(0.1 * rate, 0.1), f"{name}: {measured}/s"
        # No position before the estimator has one (~35 s): asking does not help.
        assert "GLOBAL_POSITION_INT" not in counts
        # PX4 has no EKF_STATUS_REPORT: asked for it, 1.15.4 answers FAILED.
        assert sim.streams.set_interval(mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT, 1e6) == (
            mav.MAV_RESULT_FAILED
        )
    finally:
        conn.close()
        sim.close()
