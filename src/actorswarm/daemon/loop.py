"""The asyncio host loop: one endpoint, one transport, the wall clock.

:func:`serve` is the only place a daemon (or a ground-station command) meets time and the
network. Packets arrive on the transport's threads and are queued into the loop with
``call_soon_threadsafe``; the loop wakes for a packet or for the endpoint's next deadline,
hands over the bytes or ticks it with the current time, and sends what it produced. The
endpoint itself never sees a clock or a socket, which is why the same objects run in the
simulator.

The clock is :func:`time.monotonic`: timers must not jump with the wall clock's
corrections (NTP), and the swarm never compares clocks across platforms.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Protocol

from actorswarm.core.wire import URGENT
from actorswarm.daemon.endpoint import Endpoint
from actorswarm.security.guard import PacketGuard

__all__ = ["Transport", "clock", "flush", "serve"]

#: Longest sleep between two looks at the endpoint (seconds), even with no deadline.
_IDLE = 0.5


def clock() -> float:
    """The host's time, seconds (monotonic)."""
    return time.monotonic()


class Transport(Protocol):
    def send(self, dst: int | None, data: bytes, *, urgent: bool = False) -> None: ...


async def serve(
    endpoint: Endpoint,
    transport: Transport,
    inbox: asyncio.Queue[bytes],
    stop: asyncio.Event,
    *,
    now: Callable[[], float] = clock,
    on_wake: Callable[[float], None] | None = None,
    guard: PacketGuard | None = None,
) -> None:
    """Drive ``endpoint`` until ``stop`` is set: feed it the packets put in ``inbox`` (by
    the transport's callback), tick it at its deadlines, send what it produces.
    ``on_wake(now)`` runs after every wake (a daemon's status file, a command's progress).

    With ``guard`` (DESIGN.md §2: security between the core and the transport) every packet
    sent is sealed and every packet received is checked — authenticated, not replayed, an
    operator's signed — before the endpoint sees it; what fails is counted in
    ``guard.rejected`` and dropped."""
    stopping = asyncio.ensure_future(stop.wait())
    try:
        while not stop.is_set():
            t = now()
            endpoint.tick(t)
            flush(endpoint, transport, guard)
            if on_wake is not None:
                on_wake(t)
            deadline = endpoint.next_deadline()
            wait = _IDLE if deadline is None else min(_IDLE, max(0.0, deadline - now()))
            getting = asyncio.ensure_future(inbox.get())
            done, _ = await asyncio.wait(
                {getting, stopping}, timeout=wait, return_when=asyncio.FIRST_COMPLETED
            )
            if getting in done:
                t = now()
                _receive(endpoint, getting.result(), t, guard)
                # Whatever else arrived meanwhile, in one go.
                while not inbox.empty():
                    _receive(endpoint, inbox.get_nowait(), t, guard)
                flush(endpoint, transport, guard)
            else:
                getting.cancel()
    finally:
        stopping.cancel()


def _receive(endpoint: Endpoint, data: bytes, now: float, guard: PacketGuard | None) -> None:
    if guard is None:
        endpoint.receive(data, now)
        return
    packet = guard.check(data, now)
    if packet is not None:
        endpoint.receive_packet(packet, now)


def flush(endpoint: Endpoint, transport: Transport, guard: PacketGuard | None = None) -> None:
    """Send everything ``endpoint`` has produced (sealed by ``guard`` when given)."""
    for out in endpoint.drain_outgoing():
        data = out.data if guard is None else guard.seal(out.data)
        transport.send(out.dst, data, urgent=out.channel == URGENT)
