"""What every transport offers the host above it: send opaque bytes to one platform or all,
and (a transport whose packets arrive on threads of its own) hand over what arrived in
batches.

Two implementations: :class:`~actorswarm.transport.zenoh_transport.ZenohTransport` on real
robots and :class:`~actorswarm.sim.radio.RadioPort` in the simulator. Both sit under one
:class:`~actorswarm.security.pipeline.Pipeline` (seal, check, count), so the simulator does
the per-packet work a daemon does. The simulator's radio delivers through a callback in its
own time; Zenoh's packets wait in bounded channels until the host's loop drains them
(:class:`Receiver`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

__all__ = ["Receiver", "Transport"]


class Transport(Protocol):
    """Sends a sealed packet: to platform ``dst``, or to every other platform (``dst`` None).

    ``urgent`` marks the ground station's traffic (sent before swarm traffic where the
    transport has priorities); ``kind`` names the packet's type for a transport that keeps
    statistics per type (the simulated radio). Never blocks; a packet that cannot go is
    dropped, as on the air.
    """

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        """Put ``data`` on the way to ``dst`` (None: everybody else)."""
        ...


class Receiver(Protocol):
    """Packets that arrived and wait to be taken, in batches, by the host's loop.

    :meth:`watch` gives the receiver its wake-up: it calls ``wake()`` (from any thread) when
    packets start waiting, once per burst, not once per packet — or, for packets that may
    wait, not at all, and the loop then sleeps no longer than :attr:`longest_sleep`.
    :meth:`drain` (on the loop's thread) takes what waits, the ground station's channel
    first; after a drain that took everything, the next packet calls ``wake`` again, so no
    packet waits unseen.
    """

    #: The longest the loop may sleep between two drains (seconds), for packets that wait
    #: without a wake-up of their own (a channel drained on the loop's other wakes); None:
    #: every packet wakes the loop.
    longest_sleep: float | None

    def watch(self, wake: Callable[[], None]) -> None:
        """Call ``wake`` whenever packets start waiting (once per burst, any thread)."""
        ...

    def drain(self, limit: int) -> list[bytes]:
        """At most ``limit`` waiting packets, oldest first within a channel, unicasts (the
        ground station's) before broadcasts. Never blocks. Fewer than ``limit``: whatever
        still waits, or arrives, calls ``wake`` again; exactly ``limit``: more may wait
        without a new ``wake``, the loop drains again before it sleeps."""
        ...
