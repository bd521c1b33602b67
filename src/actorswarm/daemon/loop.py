"""The asyncio host loop: one endpoint, one transport, the wall clock.

:func:`serve` is the only place a daemon (or a ground-station command) meets time and the
network. Packets wait at the transport (Zenoh's receive channels,
:class:`~actorswarm.transport.base.Receiver`) and an :class:`Inbox` wakes the loop once per
burst; the loop wakes for packets or for the endpoint's next deadline, takes every packet
that waits (at most :data:`BATCH_LIMIT`, the ground station's first) as one batch, hands
it to the endpoint, ticks it with the current time, and sends what it produced: the
endpoint's ``ready()``, its one way out, taken once per wake — or, for a platform, after
every packet too (``flush_each``: its task engine reacts to each packet before the next).
The endpoint itself never sees a clock or a socket, which is why the same objects run in
the simulator.

Packets go in and out through one :class:`~actorswarm.security.pipeline.Pipeline`, the
same the simulator uses: sealed once on the way out, checked over the raw bytes before
their body is decoded on the way in (the endpoint takes checked packets only). With a
:class:`Traffic` it counts the packets and bytes it hands to the transport and takes from
it: what travels on the wire, sealed.

The clock is :func:`time.monotonic`: timers must not jump with the wall clock's
corrections (NTP), and the swarm never compares clocks across platforms.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections import deque
from collections.abc import Callable

from actorswarm.daemon.endpoint import Endpoint
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline, Traffic
from actorswarm.transport.base import Receiver, Transport

__all__ = ["BATCH_LIMIT", "Inbox", "Traffic", "Transport", "clock", "flush", "serve"]

#: Longest sleep between two looks at the endpoint (seconds), even with no deadline.
_IDLE = 0.5

#: Most packets one wake takes in: a flood is handled in slices with the endpoint's ticks,
#: its output and the loop's other tasks in between (a slice of heartbeats is some 7 ms of
#: checking, decoding and handling at 28 µs each, docs/deploying.md), never in one
#: stretch. Twice a Zenoh receive channel
#: (:data:`~actorswarm.transport.zenoh_transport.RX_CAPACITY`): what waits in both is one
#: batch.
BATCH_LIMIT = 256


def clock() -> float:
    """The host's time, seconds (monotonic)."""
    return time.monotonic()


class Inbox:
    """What wakes the loop, and the packets it takes when it wakes.

    Packets come from ``source`` (a transport that keeps them until drained: Zenoh's
    receive channels), which calls :meth:`notify` once per burst, or are :meth:`put` one by
    one (an in-process transport, tests). Both are thread-safe and schedule one wake of the
    loop however many calls come before it runs. :meth:`wait` is the loop's one way to
    sleep: one future and one timer per wake, nothing else — with 30 peers heartbeating at
    10 Hz the loop wakes hundreds of times a second, and ``asyncio.wait`` over several
    tasks cost more than the protocol.

    Counters (for a status report, :meth:`as_dict`): ``batches`` taken that held a packet,
    ``packets`` in them, the ``largest_batch``, and ``cut_batches``: batches that stopped
    at their limit with more waiting (the loop then drains again before it sleeps).
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, source: Receiver | None = None) -> None:
        self._loop = loop
        self._packets: deque[bytes] = deque()
        self._lock = threading.Lock()
        self._armed = False
        self._poked = False
        self._more = False
        self._waiter: asyncio.Future[None] | None = None
        self.source = source
        self.batches = 0
        self.packets = 0
        self.largest_batch = 0
        self.cut_batches = 0
        if source is not None:
            source.watch(self.notify)

    def put(self, data: bytes) -> None:
        """Queue ``data`` (thread-safe)."""
        self._packets.append(data)
        self.notify()

    def notify(self) -> None:
        """Packets wait: wake the loop (thread-safe; one wake however many calls)."""
        with self._lock:
            if self._armed:
                return  # a wake-up is already on its way
            self._armed = True
        # A closed loop raises: nobody is left to take the packets then.
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(self._wake)

    def poke(self) -> None:
        """End the current (or next) :meth:`wait` now (on the loop's thread)."""
        self._poked = True
        self._release()

    def _wake(self) -> None:
        with self._lock:
            self._armed = False
        self.poke()

    def _release(self) -> None:
        waiter = self._waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    async def wait(self, timeout: float) -> None:
        """Return when packets are queued, :meth:`notify` or :meth:`poke` was called, the
        last :meth:`take` left packets waiting, or ``timeout`` seconds passed (at most the
        source's ``longest_sleep``), whichever comes first. A :meth:`take` that left
        packets waiting is followed by one turn of the event loop only, so other tasks run
        between two slices of a flood."""
        if self._more:
            self._more = False
            await asyncio.sleep(0)
            return
        if self._packets or self._poked:
            self._poked = False
            return
        if self.source is not None and self.source.longest_sleep is not None:
            timeout = min(timeout, self.source.longest_sleep)
        waiter = self._waiter = self._loop.create_future()
        timer = self._loop.call_later(timeout, self._release)
        try:
            await waiter
        finally:
            timer.cancel()
            self._waiter = None
            self._poked = False

    def take(self, limit: int = BATCH_LIMIT) -> list[bytes]:
        """The packets that wait, at most ``limit``: those :meth:`put` first, oldest first,
        then the source's (its unicasts, the ground station's, before its broadcasts). On
        the loop's thread."""
        out: list[bytes] = []
        packets = self._packets
        while packets and len(out) < limit:
            out.append(packets.popleft())
        if self.source is not None and len(out) < limit:
            out += self.source.drain(limit - len(out))
        self._more = len(out) >= limit
        if out:
            self.batches += 1
            self.packets += len(out)
            self.largest_batch = max(self.largest_batch, len(out))
            if self._more:
                self.cut_batches += 1
        return out

    def as_dict(self) -> dict[str, int]:
        """The counters: ``batches``, ``packets``, ``largest_batch``, ``cut_batches``."""
        return {
            "batches": self.batches,
            "packets": self.packets,
            "largest_batch": self.largest_batch,
            "cut_batches": self.cut_batches,
        }


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
    flush_each: bool = False,
) -> None:
    """Drive ``endpoint`` until ``stop`` is set: feed it, one batch per wake, the packets
    ``inbox`` takes (from the transport's receive channels, or put there), tick it at its
    deadlines, send what it produces (its ``ready()``) after the tick — and, with
    ``flush_each``, after every packet of the batch too (a
    :class:`~actorswarm.daemon.endpoint.PlatformEndpoint`, whose engine reacts when its
    ``ready()`` is taken; the ground station numbers its streams' packets when taken, and is
    taken once per wake).
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
            pipeline.receive_all(inbox.take(), t, flush_each=flush_each)
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
    """Send everything ``endpoint`` has produced now (its ``ready()``), outside the loop's
    wakes (sealed by ``guard`` when given, counted in ``traffic`` when given)."""
    Pipeline(endpoint, transport, guard or PacketGuard.insecure(), traffic).flush()
