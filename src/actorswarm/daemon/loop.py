"""The asyncio host loop: one endpoint, one transport, the wall clock.

:func:`serve` is the only place a daemon (or a ground-station command) meets time and the
network. Packets arrive on the transport's threads and are queued in an :class:`Inbox`,
which wakes the loop once per batch; the loop wakes for packets or for the endpoint's next
deadline, hands over the bytes and ticks it with the current time, and sends what it
produced. The
endpoint itself never sees a clock or a socket, which is why the same objects run in the
simulator.

Packets go in and out through one :class:`~actorswarm.security.pipeline.Pipeline`, the
same the simulator uses: sealed once on the way out, checked over the raw bytes before
their body is decoded on the way in. With a :class:`Traffic` it counts the packets and
bytes it hands to the transport and takes from it: what travels on the wire, sealed.

The clock is :func:`time.monotonic`: timers must not jump with the wall clock's
corrections (NTP), and the swarm never compares clocks across platforms.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections import deque
from collections.abc import Callable

from actorswarm.daemon.endpoint import Endpoint
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline, Traffic
from actorswarm.transport.base import Transport

__all__ = ["Inbox", "Traffic", "Transport", "clock", "flush", "serve"]

#: Longest sleep between two looks at the endpoint (seconds), even with no deadline.
_IDLE = 0.5


def clock() -> float:
    """The host's time, seconds (monotonic)."""
    return time.monotonic()


class Inbox:
    """Packets handed from the transport's threads to the loop.

    :meth:`put` may be called from any thread; it wakes the loop once per batch, not once
    per packet. :meth:`wait` is the loop's one way to sleep: one future and one timer per
    wake, nothing else — with 30 peers heartbeating at 10 Hz the loop wakes hundreds of
    times a second, and ``asyncio.wait`` over several tasks cost more than the protocol.
    """

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop
        self._packets: deque[bytes] = deque()
        self._lock = threading.Lock()
        self._armed = False
        self._poked = False
        self._waiter: asyncio.Future[None] | None = None

    def put(self, data: bytes) -> None:
        """Queue ``data`` (thread-safe)."""
        self._packets.append(data)
        with self._lock:
            if self._armed:
                return  # a wake-up is already on its way
            self._armed = True
        self._loop.call_soon_threadsafe(self._wake)

    def poke(self) -> None:
        """End the current (or next) :meth:`wait` now (on the loop's thread)."""
        self._poked = True
        self._release()

    def _wake(self) -> None:
        with self._lock:
            self._armed = False
        self._release()

    def _release(self) -> None:
        waiter = self._waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    async def wait(self, timeout: float) -> None:
        """Return when packets are queued, :meth:`poke` was called, or ``timeout`` seconds
        passed, whichever comes first."""
        if self._packets or self._poked:
            self._poked = False
            return
        waiter = self._waiter = self._loop.create_future()
        timer = self._loop.call_later(timeout, self._release)
        try:
            await waiter
        finally:
            timer.cancel()
            self._waiter = None
            self._poked = False

    def take(self) -> list[bytes]:
        """Every packet queued so far, oldest first (on the loop's thread)."""
        out = []
        packets = self._packets
        while packets:
            out.append(packets.popleft())
        return out


async def serve(
    endpoint: Endpoint,
    transport: Transport,
    inbox: Inbox,
    stop: asyncio.Event,
    *,
    now: Callable[[], float] = clock,
    on_wake: Callable[[float], None] | None = None,
    guard: PacketGuard | None = None,
    traffic: Traffic | None = None,
) -> None:
    """Drive ``endpoint`` until ``stop`` is set: feed it the packets put in ``inbox`` (by
    the transport's callback), tick it at its deadlines, send what it produces.
    ``on_wake(now)`` runs after every wake (a daemon's status file, a command's progress).

    Every packet goes through one :class:`~actorswarm.security.pipeline.Pipeline`: sealed by
    ``guard`` on the way out; on the way in checked — the frame, the tag and the replay
    window over the raw bytes, an operator's signature — and only then decoded, the ground
    station's packets of a batch first; what fails is counted in ``guard.rejected`` and
    dropped. Without a guard, an insecure one (frame checks only). With ``traffic`` every
    packet in and out is counted."""
    pipeline = Pipeline(endpoint, transport, guard or PacketGuard.insecure(), traffic)
    stopping = asyncio.ensure_future(stop.wait())
    stopping.add_done_callback(lambda _: inbox.poke())
    try:
        while not stop.is_set():
            t = now()
            pipeline.receive_all(inbox.take(), t)
            endpoint.tick(t)
            pipeline.flush()
            if on_wake is not None:
                on_wake(t)
            deadline = endpoint.next_deadline()
            await inbox.wait(_IDLE if deadline is None else min(_IDLE, max(0.0, deadline - now())))
    finally:
        stopping.cancel()


def flush(
    endpoint: Endpoint,
    transport: Transport,
    guard: PacketGuard | None = None,
    traffic: Traffic | None = None,
) -> None:
    """Send everything ``endpoint`` has produced now, outside the loop's wakes (sealed by
    ``guard`` when given, counted in ``traffic`` when given)."""
    Pipeline(endpoint, transport, guard or PacketGuard.insecure(), traffic).flush()
