"""What every transport offers the host above it: send opaque bytes to one platform or all.

Two implementations: :class:`~actorswarm.transport.zenoh_transport.ZenohTransport` on real
robots and :class:`~actorswarm.sim.radio.RadioPort` in the simulator. Both receive through a
callback they were given, both sit under one :class:`~actorswarm.security.pipeline.Pipeline`
(seal, check, count), so the simulator does the per-packet work a daemon does.
"""

from __future__ import annotations

from typing import Protocol

__all__ = ["Transport"]


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
