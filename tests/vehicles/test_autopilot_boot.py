"""The simulated autopilot boots as the real ones do: arming refused with their words until
``ready_after``, positions withheld or zero until the estimator has one, the pre-arm bit
healthy before arming is accepted (ArduPilot), STATUSTEXT only to a ground station and in
chunks (PX4), and a TCP clock that starts with the first client. A scripted ground station
on UDP loopback; the autopilot's clock is given, so the times are exact."""

from __future__ import annotations

import socket
import time
from collections.abc import Iterator
from typing import Any, Literal

import pytest
from pymavlink import mavutil
from tests.vehicles.helpers import free_port

from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
from actorswarm.vehicles.mavlink.boot import DEFAULT_READY_AFTER, Boot, chunks
from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.frame import MissionFrame

HOME = MissionFrame(47.397742, 8.545594, 488.0)
ARM = mav.MAV_CMD_COMPONENT_ARM_DISARM


class Bench:
    """One simulated autopilot on a clock the test moves, and a ground station."""

    def __init__(self, kind: Literal["ardupilot", "px4"], ready_after: float) -> None:
        port = free_port()
        self.now = 100.0
        self.sim = SimAutopilot(
            AutopilotOptions(f"udpin:127.0.0.1:{port}", HOME, kind=kind, ready_after=ready_after),
            clock=lambda: self.now,
        )
        self.gcs = mavutil.mavlink_connection(
            f"udpout:127.0.0.1:{port}", source_system=245, source_component=191
        )
        self.heard: list[Any] = []

    def at(self, t: float, *, gcs: bool = False) -> list[Any]:
        """Move to ``t`` s after boot; what the autopilot sent on the way."""
        kind = mav.MAV_TYPE_GCS if gcs else mav.MAV_TYPE_ONBOARD_CONTROLLER
        self.gcs.mav.heartbeat_send(kind, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        return self._run(100.0 + t)

    def ask(self, intervals: dict[int, float]) -> None:
        """Ask for messages at these intervals (seconds), as a ground station must of
        ArduPilot's first serial port."""
        for message_id, interval in intervals.items():
            self.gcs.mav.command_long_send(
                1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, message_id, interval * 1e6, 0, 0, 0, 0, 0
            )

    def arm(self, t: float) -> tuple[int, list[Any]]:
        self.gcs.mav.command_long_send(1, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0)
        heard = self._run(100.0 + t)
        acks = [m.result for m in heard if m.get_type() == "COMMAND_ACK" and m.command == ARM]
        assert acks, "no COMMAND_ACK"
        return acks[-1], heard

    def _run(self, until: float) -> list[Any]:
        out: list[Any] = []
        self.now = max(self.now, until - 0.3)
        for _ in range(12):
            self.now = min(self.now + 0.03, until) if self.now < until else until
            time.sleep(0.01)
            self.sim.service(self.now)
            while (m := self.gcs.recv_match(blocking=False)) is not None:
                out.append(m)
        time.sleep(0.02)
        while (m := self.gcs.recv_match(blocking=False)) is not None:
            out.append(m)
        self.heard += out
        return out

    def close(self) -> None:
        self.gcs.close()
        self.sim.close()


@pytest.fixture
def bench(request: pytest.FixtureRequest) -> Iterator[Bench]:
    kind, ready_after = request.param
    b = Bench(kind, ready_after)
    yield b
    b.close()


def texts(messages: list[Any]) -> list[str]:
    return [m.text for m in messages if m.get_type() == "STATUSTEXT"]


def of(messages: list[Any], kind: str) -> list[Any]:
    return [m for m in messages if m.get_type() == kind]


def test_the_default_boots_are_the_measured_ones() -> None:
    assert DEFAULT_READY_AFTER == {"ardupilot": 40.0, "px4": 35.0}
    ap = Boot("ardupilot", 40.0)
    assert not ap.at(17.0).home and ap.at(18.0).home  # EKF origin at ~18 s
    assert ap.at(23.5).prearm_ok and not ap.at(23.5).armable  # healthy bit, still refused
    assert ap.at(39.5).ekf_flags & mav.EKF_POS_HORIZ_ABS and ap.at(40.0).armable
    px4 = Boot("px4", 35.0)
    assert px4.at(34.0).position == "none" and px4.at(35.0).position == "real"
    assert px4.at(2.0).home and px4.at(2.0).refused_with == mav.MAV_RESULT_TEMPORARILY_REJECTED


def test_px4_splits_long_texts_into_chunks() -> None:
    pieces = chunks("Arming denied: Resolve system health failures first\t", 7)
    assert pieces == [("Arming denied: Resolve system health failures firs", 7, 0), ("t\t", 7, 1)]
    assert chunks("short", 7) == [("short", 0, 0)]


@pytest.mark.parametrize("bench", [("ardupilot", 2.0)], indirect=True)
def test_ardupilot_refuses_until_ready_with_its_reasons(bench: Bench) -> None:
    heard = bench.at(0.12)  # "ArduPilot Ready" at 5.5 % of the boot
    assert "ArduPilot Ready" in texts(heard)
    bench.ask(
        {
            mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.25,
            mav.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
            mav.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
            mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT: 1.0,
        }
    )
    result, heard = bench.arm(0.15)
    assert result == mav.MAV_RESULT_FAILED
    assert {"Arm: Accels inconsistent", "Arm: AHRS: waiting for home"} <= set(texts(heard))
    positions = of(bench.heard, "GLOBAL_POSITION_INT")
    assert positions and all(p.lat == 0 and p.lon == 0 for p in positions)  # no origin yet
    assert not of(bench.heard, "HOME_POSITION")
    heard = bench.at(1.0) + bench.at(1.5) + bench.at(1.9)  # the origin is set...
    healthy = [
        m.onboard_control_sensors_health & mav.MAV_SYS_STATUS_PREARM_CHECK
        for m in of(bench.heard, "SYS_STATUS")
    ]
    assert healthy[-1] and not healthy[0]  # ... the pre-arm bit turns good ...
    assert of(heard, "GLOBAL_POSITION_INT")[-1].lat != 0
    assert not of(heard, "EKF_STATUS_REPORT")[-1].flags & mav.EKF_POS_HORIZ_ABS
    result, heard = bench.arm(1.92)  # ... and arming is still refused
    assert result == mav.MAV_RESULT_FAILED
    assert "Arm: Need Position Estimate" in texts(heard)
    assert "PreArm: Need Position Estimate" in texts(bench.heard)  # the repeated nag
    heard = bench.at(2.5) + bench.at(3.0)
    assert of(heard, "EKF_STATUS_REPORT")[-1].flags & mav.EKF_POS_HORIZ_ABS
    assert of(heard, "GPS_RAW_INT")[-1].fix_type == 3
    result, _ = bench.arm(3.1)
    assert result == mav.MAV_RESULT_ACCEPTED and bench.sim.armed


@pytest.mark.parametrize("bench", [("px4", 2.0)], indirect=True)
def test_px4_rejects_for_now_and_speaks_only_to_a_ground_station(bench: Bench) -> None:
    bench.at(0.2)
    result, heard = bench.arm(0.3)
    assert result == mav.MAV_RESULT_TEMPORARILY_REJECTED
    assert texts(heard) == []  # an onboard controller's link gets no STATUSTEXT
    assert of(bench.heard, "HOME_POSITION") and not of(bench.heard, "GLOBAL_POSITION_INT")
    assert not of(bench.heard, "EKF_STATUS_REPORT")  # PX4 does not send it
    bench.at(0.4, gcs=True)
    result, heard = bench.arm(0.5)
    assert result == mav.MAV_RESULT_TEMPORARILY_REJECTED
    parts = [m for m in of(heard, "STATUSTEXT") if m.text.startswith("Arming") or m.chunk_seq]
    assert [m.chunk_seq for m in parts] == [0, 1] and parts[0].id == parts[1].id != 0
    assert parts[0].text + parts[1].text == "Arming denied: Resolve system health failures first\t"
    heard = bench.at(2.0, gcs=True)
    assert of(heard, "GLOBAL_POSITION_INT")
    result, _ = bench.arm(2.1)
    assert result == mav.MAV_RESULT_ACCEPTED


def test_a_tcp_autopilot_starts_its_clock_with_the_first_client() -> None:
    port = free_port(socket.SOCK_STREAM)
    now = [50.0]
    sim = SimAutopilot(
        AutopilotOptions(f"tcpin:127.0.0.1:{port}", HOME, ready_after=5.0), clock=lambda: now[0]
    )
    try:
        sim.service(now[0])
        now[0] = 80.0
        sim.service(now[0])
        assert sim.boot_time(now[0]) == 0.0  # nobody connected: not booted
        client = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=245)
        try:
            for _ in range(50):
                sim.service(now[0])
                if sim.boot_time(now[0] + 1) > 0:
                    break
                time.sleep(0.01)
            now[0] = 82.0
            assert sim.boot_time(now[0]) == pytest.approx(2.0)
        finally:
            client.close()
    finally:
        sim.close()
