"""The one path every packet takes between an endpoint and its transport.

Theory of operation
-------------------
One way out: the endpoint (a core :class:`~actorswarm.core.node.Node`, a platform endpoint,
the ground station) encodes each packet once, with an empty authentication slot, and gives
it up only through its ``ready()``; :meth:`Pipeline.flush` takes it and sends its packets
(:meth:`Pipeline.send` sends the packets of a ``ready()`` the host took itself, as the
simulator does to read a node's events). The :class:`~actorswarm.security.guard.PacketGuard`
puts the tag in by slicing (one HMAC, one CRC) and the bytes go to the transport.

One way in: :meth:`Pipeline.receive` gives the guard the raw bytes; the frame check, the tag
and the replay window come first, and only a packet that passed them is decoded — once — and
given to the endpoint's ``receive_packet``. No endpoint takes bytes itself: every packet a
node or the ground station reads passed a guard. A batch (:meth:`Pipeline.receive_all`, what
arrived while the host slept) is handed over operator traffic first: the ground station's
packets (sender 0, read from the decoded header) before the swarm's, as the urgent channel
promises; with ``flush_each`` the endpoint's output is sent after every packet handed over,
for an endpoint that must react to each packet before the next one comes (a platform's task
engine, :class:`~actorswarm.daemon.endpoint.PlatformEndpoint`).

The daemon's loop (:func:`actorswarm.daemon.loop.serve`) and the simulator's host
(:class:`actorswarm.sim.swarm.SimSwarm`) both drive endpoints through a pipeline, so the
simulator's figures include the per-packet work a real platform does. An insecure guard
(:meth:`~actorswarm.security.guard.PacketGuard.insecure`) checks only the frame.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from actorswarm.core.node import Outgoing, Ready
from actorswarm.core.wire import GROUND_STATION, URGENT, Packet
from actorswarm.security.guard import PacketGuard

if TYPE_CHECKING:  # the shape of a transport only: security sits on the core alone
    from actorswarm.transport.base import Transport

__all__ = ["PacketEndpoint", "Pipeline", "Traffic"]


class PacketEndpoint(Protocol):
    """What a pipeline serves: it takes checked packets (its one way in) and gives encoded
    ones with everything else it produced, all at once (its one way out)."""

    def receive_packet(self, packet: Packet, now: float) -> None: ...

    def ready(self) -> Ready: ...


@dataclass(slots=True)
class Traffic:
    """Packets and bytes a pipeline sent and received, counted where the bytes meet the
    transport: a packet sent is one :meth:`Transport.send` (a broadcast counts once, however
    many peers the transport copies it to), its size is the sealed packet's; a packet
    received is one the transport delivered, counted before it is checked (refused ones
    too). ``at_wake`` holds the counters as they were when the current batch began, before
    its packets were taken in: what a report of something that happened in the batch
    compares against."""

    sent_packets: int = 0
    sent_bytes: int = 0
    recv_packets: int = 0
    recv_bytes: int = 0
    at_wake: tuple[int, int, int, int] = (0, 0, 0, 0)

    def counters(self) -> tuple[int, int, int, int]:
        """``(sent_packets, sent_bytes, recv_packets, recv_bytes)`` now."""
        return self.sent_packets, self.sent_bytes, self.recv_packets, self.recv_bytes

    def as_dict(self) -> dict[str, int]:
        return {
            "sent_packets": self.sent_packets,
            "sent_bytes": self.sent_bytes,
            "recv_packets": self.recv_packets,
            "recv_bytes": self.recv_bytes,
        }


class Pipeline:
    """``endpoint``'s packets to and from ``transport``, sealed and checked by ``guard``,
    counted in ``traffic`` when one is given."""

    __slots__ = ("endpoint", "guard", "traffic", "transport")

    def __init__(
        self,
        endpoint: PacketEndpoint,
        transport: Transport,
        guard: PacketGuard,
        traffic: Traffic | None = None,
    ) -> None:
        self.endpoint = endpoint
        self.transport = transport
        self.guard = guard
        self.traffic = traffic

    def receive(self, data: bytes, now: float) -> bool:
        """Check ``data`` and hand the packet to the endpoint; False when it was refused
        (counted by reason in ``guard.rejected``)."""
        if self.traffic is not None:
            self.traffic.recv_packets += 1
            self.traffic.recv_bytes += len(data)
        packet = self.guard.check(data, now)
        if packet is None:
            return False
        self.endpoint.receive_packet(packet, now)
        return True

    def receive_all(self, batch: Iterable[bytes], now: float, *, flush_each: bool = False) -> int:
        """Check every packet of ``batch`` and hand the accepted ones over, the ground
        station's first (in arrival order otherwise); how many were accepted. With
        ``flush_each`` the endpoint's output is sent (:meth:`flush`) after every packet
        handed over, not left for the host to send once after the batch."""
        traffic = self.traffic
        if traffic is not None:
            traffic.at_wake = traffic.counters()
        check = self.guard.check
        swarm: list[Packet] = []
        operator: list[Packet] = []
        for data in batch:
            if traffic is not None:
                traffic.recv_packets += 1
                traffic.recv_bytes += len(data)
            packet = check(data, now)
            if packet is not None:
                (operator if packet.sender == GROUND_STATION else swarm).append(packet)
        receive = self.endpoint.receive_packet
        for packet in operator:
            receive(packet, now)
            if flush_each:
                self.flush()
        for packet in swarm:
            receive(packet, now)
            if flush_each:
                self.flush()
        return len(operator) + len(swarm)

    def flush(self) -> int:
        """Take the endpoint's ``ready()`` and seal and send its packets; how many. For
        endpoints whose ``ready()`` holds packets only (the ground station, a platform
        endpoint, whose engine reads the node's events): a host that reads events (a
        node's) takes ``ready()`` itself and calls :meth:`send`."""
        return self.send(self.endpoint.ready().packets)

    def send(self, packets: Iterable[Outgoing]) -> int:
        """Seal and send ``packets``, taken from the endpoint by the host (the packets of a
        node's :meth:`~actorswarm.core.node.Node.ready`), in order; how many."""
        sent = 0
        seal = self.guard.seal
        send = self.transport.send
        traffic = self.traffic
        for out in packets:
            data = seal(out.data)
            send(out.dst, data, urgent=out.channel == URGENT, kind=out.kind)
            sent += 1
            if traffic is not None:
                traffic.sent_packets += 1
                traffic.sent_bytes += len(data)
        return sent
