"""The MAVLink 2 dialect every module of this layer uses, loaded once.

Only the generated dialect module is loaded (``pymavlink.dialects.v20.ardupilotmega``:
``common`` and ArduPilot's messages, such as ``EKF_STATUS_REPORT``; it decodes PX4's
messages too), never :mod:`pymavlink.mavutil`: that module loads NumPy and every dialect,
33 MiB of a daemon's memory, for connection classes this layer has of its own
(:mod:`~actorswarm.vehicles.mavlink.link`).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

__all__ = ["command_name", "mav", "message_name", "result_name"]


def command_name(command: int) -> str:
    """``MAV_CMD_NAV_TAKEOFF`` for 22 (the number itself when unknown)."""
    entry = mav.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"command {command}"


def result_name(result: int) -> str:
    """``MAV_RESULT_DENIED`` for 2 (the number itself when unknown)."""
    entry = mav.enums["MAV_RESULT"].get(result)
    return entry.name if entry is not None else f"result {result}"


def message_name(message_id: int) -> str:
    """``EKF_STATUS_REPORT`` for 193 (``message 999`` when the dialect does not know it)."""
    cls = mav.mavlink_map.get(message_id)
    return str(cls.msgname) if cls is not None else f"message {message_id}"
