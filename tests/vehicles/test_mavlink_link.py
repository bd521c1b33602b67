"""Links that come and go: a TCP autopilot that vanishes and comes back is reconnected on the
adapter's own schedule, pymavlink's prints never reach the output, and closing never
raises or waits, whatever the link is doing."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable

import pytest
from pymavlink import mavutil

from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.link import Link, drain_library_lines
from actorswarm.vehicles.mavlink.vehicle import (
    LINK_LOST,
    LINK_RESTORED,
    MavlinkSettings,
    MavlinkVehicle,
)

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


class TcpAutopilot:
    """A bare autopilot on ``tcpin:``: heartbeats, nothing else."""

    def __init__(self, port: int) -> None:
        self.conn = mavutil.mavlink_connection(
            f"tcpin:127.0.0.1:{port}", source_system=1, source_component=1
        )

    def beat(self) -> None:
        self.conn.recv_match(blocking=False)  # accepts the client
        self.conn.mav.heartbeat_send(
            mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, mav.MAV_STATE_STANDBY
        )

    def close(self) -> None:
        self.conn.close()


def run_until(vehicle: MavlinkVehicle, peer: TcpAutopilot | None, what: Callable[[], bool]) -> None:
    end = time.monotonic() + 10.0
    while not what():
        assert time.monotonic() < end, "not within 10 s"
        if peer is not None:
            peer.beat()
        vehicle.service(time.monotonic())
        time.sleep(0.05)


def test_a_vanishing_tcp_autopilot_is_reconnected_quietly(
    capfd: pytest.CaptureFixture[str],
) -> None:
    port = free_tcp_port()
    peer: TcpAutopilot | None = TcpAutopilot(port)
    settings = MavlinkSettings(f"tcp:127.0.0.1:{port}", ORIGIN, link_timeout=1.0, name="p1")
    vehicle = MavlinkVehicle(settings)
    events: list[str] = []

    def raised(name: str) -> bool:
        events.extend(vehicle.drain_events())
        return name in events

    try:
        run_until(vehicle, peer, lambda: vehicle.status()["link"] == "up")
        assert peer is not None
        peer.close()  # the autopilot reboots: its TCP port closes
        peer = None
        run_until(vehicle, None, lambda: raised(LINK_LOST))
        log = vehicle.drain_log()
        broke = [f for e, f in log if e == "vehicle-link" and f["what"] == "broke"]
        assert broke and "TCP connection" in broke[0]["why"], log  # closed or reset
        # Back up: the adapter reconnects on its own schedule (once a second).
        peer = TcpAutopilot(port)
        started = time.monotonic()
        run_until(vehicle, peer, lambda: raised(LINK_RESTORED))
        assert time.monotonic() - started < 3.0
        reopened = [f for e, f in vehicle.drain_log() if e == "vehicle-link"]
        assert [f["what"] for f in reopened] == ["reopened"]
        assert "Connection refused" in reopened[0]["why"]  # what it was while down
    finally:
        began = time.monotonic()
        vehicle.close()
        assert time.monotonic() - began < 0.6
        if peer is not None:
            peer.close()
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)  # nothing of pymavlink's reaches the output


def test_closing_a_vehicle_whose_link_is_gone_never_raises() -> None:
    port = free_tcp_port()
    peer = TcpAutopilot(port)
    vehicle = MavlinkVehicle(MavlinkSettings(f"tcp:127.0.0.1:{port}", ORIGIN, name="p2"))
    vehicle.start()
    run_until(vehicle, peer, lambda: vehicle.status()["link"] == "up")
    peer.close()
    time.sleep(0.3)  # the thread sees the break and keeps retrying
    began = time.monotonic()
    vehicle.close()
    vehicle.close()  # twice is fine
    assert time.monotonic() - began < 0.6


def test_a_tcp_autopilot_not_listening_yet_is_waited_for() -> None:
    port = free_tcp_port()
    link = Link(f"tcp:127.0.0.1:{port}", who="vehicle p3", source_system=245, source_component=191)
    assert link.connection is None and link.down is not None and "cannot connect" in link.down
    assert link.read() == []
    peer = TcpAutopilot(port)
    try:
        link.maintain(time.monotonic())
        assert link.connection is not None and link.down is None
    finally:
        link.close()
        peer.close()


def test_pymavlink_prints_are_kept_as_lines(capfd: pytest.CaptureFixture[str]) -> None:
    drain_library_lines()
    mav.print("signing failure")  # type: ignore[attr-defined]  # what the dialect would say
    assert drain_library_lines() == ["signing failure"]
    assert capfd.readouterr().out == ""


def test_a_serial_link_is_read_and_its_loss_reported() -> None:
    """A serial device (a pseudo-terminal here): the autopilot's heartbeats come in; the
    device going away (the other end closed) breaks the link, which is then retried."""
    import os

    controller, device = os.openpty()
    path = os.ttyname(device)
    autopilot = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    beat = autopilot.heartbeat_encode(
        mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_PX4, 0, 0, mav.MAV_STATE_STANDBY
    )
    vehicle = MavlinkVehicle(MavlinkSettings(f"{path},57600", ORIGIN, name="p4"))
    try:
        end = time.monotonic() + 5.0
        while vehicle.status()["link"] != "up":
            assert time.monotonic() < end, "no heartbeat over the serial device"
            os.write(controller, beat.pack(autopilot))
            vehicle.service(time.monotonic())
            time.sleep(0.05)
        assert vehicle.status()["autopilot"] == "px4"
        written = os.read(controller, 4096)  # our own heartbeat and stream requests
        assert written and written[0] == 0xFD  # MAVLink 2
        os.close(controller)
        controller = -1
        end = time.monotonic() + 5.0
        while not any(e == "vehicle-link" for e, _ in vehicle.drain_log()):
            assert time.monotonic() < end, "the lost device not seen"
            vehicle.service(time.monotonic())
            time.sleep(0.05)
    finally:
        vehicle.close()
        os.close(device)
        if controller >= 0:
            os.close(controller)
