"""The MAVLink connection of one vehicle: open it, read what is there, keep only what its
autopilot says.

A link (a radio, a UDP port shared with a ground control station) may carry several
systems; :class:`MessageFilter` keeps the messages whose source is this vehicle's autopilot
(system ID, component ID) and counts the rest — foreign systems, other components,
bytes that do not parse — without ever raising. With no system ID configured it adopts the
first autopilot whose ``HEARTBEAT`` it hears.

:func:`open_connection` accepts the strings pymavlink takes for a link (``udpin:``,
``udpout:``, ``udp:``, ``udpbcast:``, ``tcp:``, ``tcpin:``, a serial device with an
optional ``,BAUD``) and nothing else — pymavlink would read any other string as a log file
to replay — and turns every failure into a :class:`MavlinkError` naming the vehicle and
the string.
"""

from __future__ import annotations

import socket
from collections import Counter
from typing import Any

from actorswarm.vehicles.mavlink.dialect import mav, mavutil
from actorswarm.vehicles.mavlink.errors import MavlinkError

__all__ = ["MessageFilter", "open_connection", "read_available"]

_NETWORK = ("udpin:", "udpout:", "udp:", "udpbcast:", "tcp:", "tcpin:")
_SERIAL = ("/dev/", "COM")
#: Messages read per call at most: a flood cannot hold the caller.
_READ_BATCH = 500


def open_connection(url: str, *, who: str, source_system: int, source_component: int) -> Any:
    """The pymavlink connection for ``url``, speaking as ``source_system``/``source_component``;
    ``who`` starts the error messages (``vehicle platform 3``)."""
    if not isinstance(url, str) or not url.startswith(_NETWORK + _SERIAL):
        raise MavlinkError(
            f"{who}: cannot open MAVLink connection {url!r}: write udpin:HOST:PORT, "
            "udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial device "
            "(/dev/ttyACM0,57600)"
        )
    if not (1 <= source_system <= 255 and 0 <= source_component <= 255):
        raise MavlinkError(f"{who}: our MAVLink system ID must be 1..255, not {source_system}")
    if url.startswith(_NETWORK):
        # pymavlink resolves a host name only when it first sends: resolve it now, so that
        # a wrong name is an error at start, not silence in the air.
        host, _, port = url.partition(":")[2].rpartition(":")
        try:
            socket.getaddrinfo(host, int(port))
        except (OSError, ValueError) as exc:
            raise MavlinkError(
                f"{who}: cannot open MAVLink connection {url!r}: "
                f"host {host!r}, port {port!r}: {exc}"
            ) from None
    try:
        connection = mavutil.mavlink_connection(
            url,
            source_system=source_system,
            source_component=source_component,
            autoreconnect=True,
        )
    except Exception as exc:  # pymavlink raises whatever its socket or serial layer raised
        raise MavlinkError(f"{who}: cannot open MAVLink connection {url!r}: {exc}") from None
    return connection


def read_available(connection: Any) -> list[Any]:
    """Every message waiting on ``connection`` (at most a batch), without blocking. A link
    error (a serial cable pulled, a refused TCP peer) reads as nothing: pymavlink reconnects
    and the heartbeat watch reports the silence."""
    out: list[Any] = []
    for _ in range(_READ_BATCH):
        try:
            message = connection.recv_match(blocking=False)
        except (OSError, ValueError):
            break
        if message is None:
            break
        out.append(message)
    return out


class MessageFilter:
    """Keeps the messages of the autopilot ``system``/``component`` (``system`` None: the
    first autopilot heard in a ``HEARTBEAT``); :attr:`dropped` counts the rest by reason."""

    def __init__(self, system: int | None, component: int = mav.MAV_COMP_ID_AUTOPILOT1) -> None:
        self.system = system
        self.component = component
        self.dropped: Counter[str] = Counter()

    def accept(self, message: Any) -> bool:
        """Whether ``message`` comes from this vehicle's autopilot."""
        kind = message.get_type()
        if kind in ("BAD_DATA", "UNKNOWN") or kind.startswith("UNKNOWN_"):
            self.dropped["malformed"] += 1
            return False
        source, component = message.get_srcSystem(), message.get_srcComponent()
        if self.system is None:
            if (
                kind == "HEARTBEAT"
                and component == self.component
                and message.autopilot != mav.MAV_AUTOPILOT_INVALID
            ):
                self.system = source
            else:
                self.dropped["before the autopilot was heard"] += 1
                return False
        if source != self.system:
            self.dropped["other system"] += 1
            return False
        if component != self.component:
            self.dropped["other component"] += 1
            return False
        return True
