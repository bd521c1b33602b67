"""The one error type of the MAVLink layer."""

from __future__ import annotations

__all__ = ["MavlinkError"]


class MavlinkError(Exception):
    """Something the MAVLink vehicle could not do; the message names the vehicle and what
    it was doing (the command, the connection string, the parameter)."""
