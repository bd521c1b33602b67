"""What the MAVLink tests share: a free loopback port and waiting for a condition."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable
from typing import Any


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    """A port on 127.0.0.1 (UDP unless ``kind`` says otherwise) that was free a moment ago."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def wait_for(
    what: str, condition: Callable[[], bool], seconds: float = 5.0, poll: float = 0.05
) -> None:
    """Return once ``condition()`` holds; fail naming ``what`` after ``seconds``."""
    end = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < end, f"not within {seconds} s: {what}"
        time.sleep(poll)


def wait_started(vehicle: Any, seconds: float = 6.0) -> None:
    """Return once the vehicle has heard its autopilot and that one's start-up is over
    (commands asked earlier wait for it: MavlinkVehicle's ``_STARTUP``)."""
    wait_for(
        "the autopilot heard and started",
        lambda: vehicle.status()["autopilot"] is not None and not vehicle.status()["starting"],
        seconds,
    )
