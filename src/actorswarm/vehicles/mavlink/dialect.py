"""The MAVLink 2 dialect every module of this layer uses, loaded once.

pymavlink picks MAVLink 1 or 2 from the ``MAVLINK20`` environment variable when
:mod:`pymavlink.mavutil` is first imported; set here, before that import, so that this
layer always speaks MAVLink 2 (signing-capable framing, extension fields). The
``ardupilotmega`` dialect includes ``common``: it decodes PX4's messages too.
"""

from __future__ import annotations

import os

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mav

__all__ = ["command_name", "mav", "mavutil", "result_name"]


def command_name(command: int) -> str:
    """``MAV_CMD_NAV_TAKEOFF`` for 22 (the number itself when unknown)."""
    entry = mav.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"command {command}"


def result_name(result: int) -> str:
    """``MAV_RESULT_DENIED`` for 2 (the number itself when unknown)."""
    entry = mav.enums["MAV_RESULT"].get(result)
    return entry.name if entry is not None else f"result {result}"
