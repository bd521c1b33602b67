"""``actorswarm autopilot``: bad options are clear errors (exit 2), a good one serves MAVLink
until SIGTERM."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pymavlink import mavutil
from typer.testing import CliRunner

from actorswarm.cli.app import app

runner = CliRunner()
SRC = str(Path(__file__).resolve().parents[2] / "src")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--home", "47.4,8.5"], "--home '47.4,8.5': write it LAT,LON,ALT"),
        (["--home", "147.4,8.5,3"], "--home '147.4,8.5,3': latitude 147.4"),
        (
            ["--home", "47.4,8.5,3", "--listen", "flight.tlog"],
            "autopilot 1: cannot open MAVLink connection 'flight.tlog'",
        ),
        (["--home", "47.4,8.5,3", "--ready-after", "-1"], "--ready-after"),
        (
            ["--home", "47.4,8.5,3", "--withhold", "EKF_STATUS"],
            "--withhold EKF_STATUS: not a MAVLink message name",
        ),
        (
            ["--home", "47.4,8.5,3", "--kind", "px4", "--frame", "plane"],
            "a px4 fixed-wing is not modelled yet",
        ),
    ],
)
def test_bad_options(args: list[str], message: str) -> None:
    result = runner.invoke(app, ["autopilot", *args])
    assert result.exit_code == 2
    assert message in result.output
    assert "Traceback" not in result.output


def test_serves_mavlink_until_sigterm() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "PYTHONPATH": SRC}
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "actorswarm",
            "autopilot",
            "--home",
            "47.4,8.5,400",
            "--listen",
            f"udpin:127.0.0.1:{port}",
            "--sysid",
            "5",
            "--kind",
            "px4",
        ],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
    )
    gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
    try:
        deadline = time.monotonic() + 20.0
        beat = None
        while beat is None and time.monotonic() < deadline:
            gcs.mav.heartbeat_send(6, 8, 0, 0, 0)  # the autopilot answers whoever spoke
            beat = gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
        assert beat is not None, "no heartbeat from the autopilot"
        assert beat.get_srcSystem() == 5 and beat.autopilot == 12  # MAV_AUTOPILOT_PX4
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        gcs.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    said = proc.stderr.read() if proc.stderr is not None else ""
    assert "autopilot 5 (px4)" in said and "ready to arm 35 s after boot" in said


def test_frame_plane_heartbeats_as_a_fixed_wing() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen(
        [sys.executable, "-m", "actorswarm", "autopilot", "--home", "47.4,8.5,400",
         "--listen", f"udpin:127.0.0.1:{port}", "--frame", "plane"],
        env={**os.environ, "PYTHONPATH": SRC},
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
    try:
        deadline = time.monotonic() + 20.0
        beat = None
        while beat is None and time.monotonic() < deadline:
            gcs.mav.heartbeat_send(6, 8, 0, 0, 0)
            beat = gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
        assert beat is not None, "no heartbeat from the autopilot"
        assert (beat.type, beat.autopilot) == (1, 3)  # MAV_TYPE_FIXED_WING, ARDUPILOTMEGA
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        gcs.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    said = proc.stderr.read() if proc.stderr is not None else ""
    assert "autopilot 1 (ardupilot, plane)" in said and "ready to arm 22 s after boot" in said
