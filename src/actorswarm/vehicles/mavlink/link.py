"""The MAVLink connection of one vehicle: open it, read what is there, keep only what its
autopilot says, reopen it when it breaks.

A link (a radio, a UDP port shared with a ground control station) may carry several
systems; :class:`MessageFilter` keeps the messages whose source is this vehicle's autopilot
(system ID, component ID) and counts the rest — foreign systems, other components,
bytes that do not parse — without ever raising. With no system ID configured it adopts the
first autopilot whose ``HEARTBEAT`` it hears.

:func:`open_connection` accepts the strings pymavlink takes for a link (``udpin:``,
``udpout:``, ``udp:`` (as ``udpin:``), ``udpbcast:``, ``tcp:``, ``tcpin:``, a serial device
with an optional ``,BAUD``) and nothing else, and turns every failure into a
:class:`MavlinkError` naming the vehicle and the string. The connections are this module's
own (:class:`Connection` over a socket or a serial port, pymavlink's generated dialect
parsing and packing the messages), not :mod:`pymavlink.mavutil`'s: that module loads NumPy
and every dialect, and its TCP client sleeps for seconds inside a read to reconnect.

:class:`Link` owns one connection and repairs it on its own schedule: a TCP peer that
closed or reset the connection, or a serial device that went away, is reopened by one
bounded attempt every :data:`REOPEN_EVERY` seconds. A UDP socket never breaks; the
heartbeat watch of the vehicle reports a silent peer. A ``tcpin:`` endpoint (the simulated
autopilot's) takes the next client when one leaves.

Whatever pymavlink itself prints is kept, never printed (:func:`drain_library_lines`; the
daemon logs the lines as structured ``vehicle-library`` records).
"""

from __future__ import annotations

import contextlib
import socket
import sys
import threading
from collections import Counter, deque
from collections.abc import Callable
from typing import Any, Final, Protocol

from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.errors import MavlinkError

__all__ = [
    "REOPEN_EVERY",
    "Connection",
    "Link",
    "LinkDown",
    "MessageFilter",
    "drain_library_lines",
    "is_mavlink1",
    "open_connection",
    "read_available",
]

_NETWORK = ("udpin:", "udpout:", "udp:", "udpbcast:", "tcp:", "tcpin:")
_SERIAL = ("/dev/", "COM")
#: Messages read per call at most: a flood cannot hold the caller.
_READ_BATCH = 500
#: Bytes read from a stream at once.
_CHUNK: Final = 4096
#: Seconds between two attempts to reopen a broken link.
REOPEN_EVERY: Final = 1.0
#: Seconds one TCP connection attempt may take (an unreachable host would take minutes).
_CONNECT_TIMEOUT: Final = 0.5
#: The first byte of a MAVLink 1 frame (MAVLink 2's is 0xFD).
_MAVLINK1_MAGIC: Final = 0xFE
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


def _silence(module_name: str) -> None:
    """Route a loaded pymavlink module's ``print`` calls to :func:`_library_line` (module
    globals come before builtins)."""
    module = sys.modules.get(module_name)
    if module is not None:
        module.print = _library_line  # type: ignore[attr-defined]


_silence(mav.__name__)
_silence("pymavlink.mavutil")  # when something else in the process loaded it


class _Port(Protocol):
    @property
    def connected(self) -> bool: ...

    def recv(self) -> bytes: ...

    def send(self, data: bytes) -> None: ...

    def close(self) -> None: ...


def _host_port(where: str) -> tuple[str, int]:
    host, _, port = where.rpartition(":")
    return host, int(port)


class _Udp:
    """A UDP socket: bound (``udpin``: answers whoever spoke last) or sending to a peer
    (``udpout``; ``udpbcast`` broadcasts until a peer answers, then speaks to it)."""

    def __init__(self, where: str, *, listen: bool, broadcast: bool = False) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setblocking(False)
        address = _host_port(where)
        self._peer: tuple[str, int] | None = None
        self._broadcast = broadcast
        if listen:
            self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self._sock.bind(address)
        else:
            self._peer = address
            if broadcast:
                self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
        self.connected = True

    def recv(self) -> bytes:
        try:
            data, peer = self._sock.recvfrom(65535)
        except OSError:  # nothing waiting, or an ICMP refusal of an earlier datagram
            return b""
        if self._peer is None or self._broadcast:
            self._peer, self._broadcast = peer, False
        return data

    def send(self, data: bytes) -> None:
        if self._peer is not None:
            with contextlib.suppress(OSError):  # a full buffer, a refused peer: dropped
                self._sock.sendto(data, self._peer)

    def close(self) -> None:
        self._sock.close()


def _stream_recv(sock: socket.socket) -> bytes:
    try:
        data = sock.recv(_CHUNK)
    except (BlockingIOError, InterruptedError):
        return b""
    except OSError as exc:
        raise LinkDown(f"the TCP connection was reset ({exc})") from None
    if not data:
        raise LinkDown("the autopilot closed the TCP connection")
    return data


def _stream_send(sock: socket.socket, data: bytes) -> None:
    try:
        sock.sendall(data)
    except (BlockingIOError, InterruptedError):
        pass  # the peer reads too slowly: dropped, as a datagram would be
    except OSError as exc:
        raise LinkDown(f"the TCP connection was reset ({exc})") from None


class _TcpClient:
    """A TCP connection to the autopilot, opened by one bounded attempt."""

    def __init__(self, where: str) -> None:
        self._sock = socket.create_connection(_host_port(where), timeout=_CONNECT_TIMEOUT)
        self._sock.setblocking(False)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.connected = True

    def recv(self) -> bytes:
        return _stream_recv(self._sock)

    def send(self, data: bytes) -> None:
        _stream_send(self._sock, data)

    def close(self) -> None:
        self._sock.close()


class _TcpServer:
    """A listening TCP endpoint serving one client at a time; a client that leaves makes
    room for the next."""

    def __init__(self, where: str) -> None:
        self._listen = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listen.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._listen.bind(_host_port(where))
        self._listen.listen(1)
        self._listen.setblocking(False)
        self._client: socket.socket | None = None

    @property
    def connected(self) -> bool:
        return self._client is not None

    def recv(self) -> bytes:
        if self._client is None:
            try:
                self._client, _ = self._listen.accept()
            except OSError:
                return b""
            self._client.setblocking(False)
            self._client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        try:
            return _stream_recv(self._client)
        except LinkDown:
            self._drop()
            return b""

    def send(self, data: bytes) -> None:
        if self._client is not None:
            try:
                _stream_send(self._client, data)
            except LinkDown:
                self._drop()

    def _drop(self) -> None:
        if self._client is not None:
            with contextlib.suppress(OSError):
                self._client.close()
            self._client = None

    def close(self) -> None:
        self._drop()
        self._listen.close()


class _Serial:
    """A serial device, ``DEVICE[,BAUD]`` (pyserial, loaded only for one)."""

    def __init__(self, where: str) -> None:
        import serial  # pyserial, loaded only for a serial link

        device, _, baud = where.partition(",")
        self._error: type[Exception] = serial.SerialException
        self._port = serial.Serial(device, int(baud or 115200), timeout=0, write_timeout=0)
        self.connected = True

    def recv(self) -> bytes:
        try:
            waiting = self._port.in_waiting
            data: bytes = self._port.read(min(max(waiting, 1), _CHUNK))
        except (OSError, self._error) as exc:
            raise LinkDown(f"the serial device failed ({exc})") from None
        return data

    def send(self, data: bytes) -> None:
        try:
            self._port.write(data)
        except (OSError, self._error) as exc:
            if "timeout" not in str(exc).lower():
                raise LinkDown(f"the serial device failed ({exc})") from None

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._port.close()


class _Mavlink(mav.MAVLink):  # type: ignore[misc]  # pymavlink's generated class is untyped
    """pymavlink's ``MAVLink``, packing MAVLink 1 frames while its connection speaks only
    MAVLink 1."""

    def send(self, mavmsg: Any, force_mavlink1: bool = False) -> None:
        super().send(mavmsg, force_mavlink1=force_mavlink1 or self.file.mavlink1_only)


class Connection:
    """MAVLink 2 over one port: :attr:`mav` packs and sends (pymavlink's generated
    ``MAVLink``, which writes through :meth:`write`), :meth:`recv_match` hands out the
    messages parsed from what arrived, one at a time, never blocking (None: nothing).
    :attr:`mavlink1_only`: speak MAVLink 1 and lose the MAVLink 2 frames that arrive, as a
    link that carries only MAVLink 1 does (the simulated autopilot's fault)."""

    def __init__(self, port: _Port, source_system: int, source_component: int) -> None:
        self._port = port
        self.mavlink1_only = False
        self.mav = _Mavlink(self, srcSystem=source_system, srcComponent=source_component)
        self.mav.robust_parsing = True  # bytes that do not parse come out as BAD_DATA
        self._queue: deque[Any] = deque()

    @property
    def connected(self) -> bool:
        """Whether a peer is there to speak to (a ``tcpin:`` endpoint: a client connected)."""
        return self._port.connected

    def write(self, data: bytes | bytearray) -> None:
        self._port.send(bytes(data))

    def recv_match(self, blocking: bool = False) -> Any:
        del blocking  # never blocks
        while not self._queue:
            data = self._port.recv()
            if not data:
                return None
            parsed = self.mav.parse_buffer(data)
            if parsed and self.mavlink1_only:
                parsed = [m for m in parsed if is_mavlink1(m)]
            if parsed:
                self._queue.extend(parsed)
        return self._queue.popleft()

    def close(self) -> None:
        self._port.close()


def is_mavlink1(message: Any) -> bool:
    """Whether ``message`` arrived as a MAVLink 1 frame."""
    buf = message.get_msgbuf()
    return bool(buf) and buf[0] == _MAVLINK1_MAGIC


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


def _connect(url: str, source_system: int, source_component: int) -> Connection:
    scheme, _, where = url.partition(":")
    port: _Port
    if scheme in ("udpin", "udp"):
        port = _Udp(where, listen=True)
    elif scheme == "udpout":
        port = _Udp(where, listen=False)
    elif scheme == "udpbcast":
        port = _Udp(where, listen=False, broadcast=True)
    elif scheme == "tcp":
        port = _TcpClient(where)
    elif scheme == "tcpin":
        port = _TcpServer(where)
    else:
        port = _Serial(url)
    return Connection(port, source_system, source_component)


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
        #: Send MAVLink 1 frames (the autopilot was heard speaking MAVLink 1 only).
        self.mavlink1 = False
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
            conn.mav.send(message, force_mavlink1=self.mavlink1)
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
        #: The autopilots of other systems heard (their HEARTBEATs), for the operator.
        self.others: set[int] = set()

    def accept(self, message: Any) -> bool:
        """Whether ``message`` comes from this vehicle's autopilot."""
        kind = message.get_type()
        if kind in ("BAD_DATA", "UNKNOWN"):
            self.dropped["malformed"] += 1
            return False
        if kind.startswith("UNKNOWN_"):
            # A message our dialect does not define (PX4's CURRENT_MODE, its events).
            self.dropped["unknown message"] += 1
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
            if kind == "HEARTBEAT" and message.autopilot != mav.MAV_AUTOPILOT_INVALID:
                self.others.add(source)
            return False
        if component != self.component:
            self.dropped["other component"] += 1
            return False
        return True
