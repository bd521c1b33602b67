"""The MAVLink connection of one vehicle: open it, read what is there, keep only what its
autopilot says, reopen it when it breaks.

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

:class:`Link` owns one such connection and repairs it on its own schedule: a TCP peer that
closed or reset the connection, or a serial device that went away, is reopened by one
bounded attempt every :data:`REOPEN_EVERY` seconds (pymavlink's own reconnection is off: it
sleeps for seconds inside a read, which held a stopping daemon for 6.5 s). A UDP socket
never breaks; the heartbeat watch of the vehicle reports a silent peer.

pymavlink prints to stdout (``Attempting reconnect``, ``EOF on TCP socket``...). Its
module's ``print`` is replaced by :func:`_library_line`: those lines are kept, never
printed, and :func:`drain_library_lines` hands them to whoever logs (the daemon writes them
as structured ``vehicle-library`` lines).
"""

from __future__ import annotations

import contextlib
import socket
import threading
from collections import Counter, deque
from collections.abc import Callable
from typing import Any, Final

from actorswarm.vehicles.mavlink.dialect import mav, mavutil
from actorswarm.vehicles.mavlink.errors import MavlinkError

__all__ = [
    "REOPEN_EVERY",
    "Link",
    "LinkDown",
    "MessageFilter",
    "drain_library_lines",
    "open_connection",
    "read_available",
]

_NETWORK = ("udpin:", "udpout:", "udp:", "udpbcast:", "tcp:", "tcpin:")
_SERIAL = ("/dev/", "COM")
#: Messages read per call at most: a flood cannot hold the caller.
_READ_BATCH = 500
#: Seconds between two attempts to reopen a broken link.
REOPEN_EVERY: Final = 1.0
#: Seconds one TCP connection attempt may take (an unreachable host would take minutes).
_CONNECT_TIMEOUT: Final = 0.5
#: pymavlink's lines kept at most until drained (the oldest go first).
_LINES_KEPT: Final = 200


class LinkDown(OSError):
    """The connection broke (a TCP peer closed or reset it, a serial device went away)."""


_lines: deque[str] = deque(maxlen=_LINES_KEPT)
_lines_lock = threading.Lock()


def _library_line(*args: object, **_: object) -> None:
    """pymavlink's ``print``: the line is kept for the log, not printed."""
    with _lines_lock:
        _lines.append(" ".join(str(a) for a in args))


def drain_library_lines() -> list[str]:
    """What pymavlink said since the last call, oldest first (shared by every link of the
    process: pymavlink does not say which connection it speaks of)."""
    with _lines_lock:
        out = list(_lines)
        _lines.clear()
        return out


# Module globals come before builtins: pymavlink's own print() calls land here.
mavutil.print = _library_line


class _Tcp(mavutil.mavtcp):  # type: ignore[misc]
    """pymavlink's TCP client, with one bounded connection attempt and no reconnection of
    its own: a closed or reset connection raises :class:`LinkDown` for :class:`Link`."""

    def do_connect(self) -> None:
        port = socket.create_connection(self.destination_addr, timeout=_CONNECT_TIMEOUT)
        port.setblocking(False)
        port.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.port = port

    def close(self) -> None:
        if self.port is not None:
            with contextlib.suppress(OSError):
                self.port.close()

    def handle_eof(self) -> None:
        raise LinkDown("the autopilot closed the TCP connection")

    def handle_disconnect(self) -> None:
        raise LinkDown("the TCP connection was reset")


def _check_url(url: str, who: str, source_system: int, source_component: int) -> None:
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


def _connect(url: str, source_system: int, source_component: int) -> Any:
    if url.startswith("tcp:"):
        return _Tcp(url[4:], source_system=source_system, source_component=source_component)
    return mavutil.mavlink_connection(
        url, source_system=source_system, source_component=source_component, retries=0
    )


def open_connection(url: str, *, who: str, source_system: int, source_component: int) -> Any:
    """The pymavlink connection for ``url``, speaking as ``source_system``/``source_component``;
    ``who`` starts the error messages (``vehicle platform 3``)."""
    _check_url(url, who, source_system, source_component)
    try:
        return _connect(url, source_system, source_component)
    except Exception as exc:  # pymavlink raises whatever its socket or serial layer raised
        raise MavlinkError(f"{who}: cannot open MAVLink connection {url!r}: {exc}") from None


def read_available(connection: Any) -> list[Any]:
    """Every message waiting on ``connection`` (at most a batch), without blocking. A link
    error (a serial cable pulled, a refused UDP peer) reads as nothing; a broken stream
    (:class:`LinkDown`) is raised for :class:`Link`."""
    out: list[Any] = []
    for _ in range(_READ_BATCH):
        try:
            message = connection.recv_match(blocking=False)
        except LinkDown:
            raise
        except (OSError, ValueError):
            break
        if message is None:
            break
        out.append(message)
    return out


class Link:
    """One vehicle's connection to ``url``, opened here (MavlinkError when the string is
    wrong or, except for a TCP peer not listening yet, when it cannot be opened) and
    reopened by :meth:`maintain` when it breaks.

    :meth:`read` and :meth:`send` never raise and never block; :meth:`maintain` may take
    up to half a second (one TCP connection attempt): call it outside any lock the
    plugins' calls need. :attr:`down` is the reason the connection is down (None: open).
    """

    def __init__(
        self,
        url: str,
        *,
        who: str,
        source_system: int,
        source_component: int,
        reopen_every: float = REOPEN_EVERY,
    ) -> None:
        _check_url(url, who, source_system, source_component)
        self.url = url
        self.who = who
        self._ids = (source_system, source_component)
        self.reopen_every = reopen_every
        self.down: str | None = None
        #: Reasons the link broke and reopened, in order, for the log: ``(what, reason)``.
        self.changes: list[tuple[str, str]] = []
        self._tried: float | None = None
        self._conn: Any = None
        self._closed = threading.Event()
        try:
            self._conn = _connect(url, *self._ids)
        except OSError as exc:
            if not url.startswith("tcp:"):
                raise MavlinkError(
                    f"{who}: cannot open MAVLink connection {url!r}: {exc}"
                ) from None
            # A TCP autopilot that is not listening yet (booting, started beside us): keep
            # trying, as after a break.
            self.down = f"cannot connect: {exc}"
        except Exception as exc:  # pymavlink raises whatever its socket or serial layer raised
            raise MavlinkError(f"{who}: cannot open MAVLink connection {url!r}: {exc}") from None

    @property
    def connection(self) -> Any:
        """The pymavlink connection (None while down)."""
        return self._conn

    def read(self) -> list[Any]:
        """What arrived (nothing while down); a break closes the connection."""
        if self._conn is None:
            return []
        try:
            return read_available(self._conn)
        except LinkDown as exc:
            self._broke(str(exc))
            return []

    def send(self, message: Any) -> None:
        """Send ``message`` (dropped while down: the heartbeat watch reports the silence)."""
        conn = self._conn
        if conn is None:
            return
        try:
            conn.mav.send(message)
        except LinkDown as exc:
            self._broke(str(exc))
        except OSError:
            pass

    def maintain(self, now: float, *, connect: Callable[[], Any] | None = None) -> None:
        """Reopen a broken connection, once every :attr:`reopen_every` seconds."""
        if self._conn is not None or self._closed.is_set():
            return
        if self._tried is not None and now - self._tried < self.reopen_every:
            return
        self._tried = now
        try:
            conn = (connect or (lambda: _connect(self.url, *self._ids)))()
        except Exception as exc:  # whatever the socket or serial layer raised
            self.down = f"cannot reconnect: {exc}"
            return
        if self._closed.is_set():  # closed while connecting (the owner's stop)
            with contextlib.suppress(Exception):
                conn.close()
            return
        self._conn = conn
        self.changes.append(("reopened", self.down or ""))
        self.down = None

    def close(self) -> None:
        """Close the connection for good (whatever state it is in; never raises)."""
        self._closed.set()
        conn, self._conn = self._conn, None
        if conn is not None:
            with contextlib.suppress(Exception):
                conn.close()

    def _broke(self, why: str) -> None:
        conn, self._conn = self._conn, None
        self.down = why
        self.changes.append(("broke", why))
        if conn is not None:
            with contextlib.suppress(Exception):
                conn.close()


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
