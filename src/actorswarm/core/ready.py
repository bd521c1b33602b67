"""What a platform's core has to say between two host calls: one collector, taken at once.

Theory of operation
-------------------
Every part of a node that produces output writes it into the node's one :class:`Collector`,
given to it at construction: the node itself (heartbeats, acknowledgements, releases,
events), its reliable streams (:mod:`.reliable`: data packets, messages given up) and its
bulletin board (:mod:`.bulletin`: bulletins, bulletins given up). The host takes all of it
with one call, :meth:`~actorswarm.core.node.Node.ready`, which returns a :class:`Ready` —
the packets to send and the events to read — and leaves the collector empty: the one way
out of the core (the ground station's endpoint, which keeps a collector of its own, is
taken the same way, :meth:`~actorswarm.ground.station.GroundStation.ready`).

Packet numbering. Each packet carries the sender's next sequence number, given when it is
encoded. The streams and the board *queue* their packets unencoded (:meth:`Collector.queue`);
whatever the node sends itself (:meth:`Collector.send`) first numbers everything queued
before it, and :meth:`Collector.take` numbers what is still queued. So every packet is
numbered in the order it was produced, whichever part produced it: what the streams queued
first keeps its place. A :class:`Ready` lists the ground-station (urgent) channel first,
then every packet in that order.

Messages given up (:class:`DeliveryFailure`, from the streams and the board) wait in
:attr:`Collector.failures` until the node turns them into
:class:`~actorswarm.core.events.DeliveryFailed` events, at the points of its step where it
reports them (after the retransmission timers ran, after the view changed): their place
among the other events is the node's to decide.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from actorswarm.core import wire
from actorswarm.core.events import CoreEvent
from actorswarm.core.wire import URGENT, Payload

__all__ = ["PROBE", "Collector", "DeliveryFailure", "Outgoing", "Ready"]

#: The :attr:`Outgoing.kind` of a heartbeat that probes a suspect or answers a probe.
PROBE = "Probe"


@dataclass(frozen=True, slots=True)
class DeliveryFailure:
    """A message given up: it missed its deadline (``dst`` None: it never found a master),
    or its destination left the swarm. Produced by the reliable streams and the bulletin
    board, carried in :attr:`Collector.failures` until the node reports it."""

    dst: int | None
    payload: Payload
    reason: str = "deadline"


@dataclass(frozen=True, slots=True)
class Outgoing:
    """A packet to transmit: ``dst`` None is a broadcast; ``kind`` names the body type, or
    ``"Probe"`` for a heartbeat that probes a suspect or answers a probe (a transport must
    not hold it back as it may a routine heartbeat: the probe window is short)."""

    dst: int | None
    data: bytes
    kind: str
    channel: int


@dataclass(frozen=True, slots=True)
class Ready:
    """Everything a node produced since the last :meth:`~actorswarm.core.node.Node.ready`:
    ``packets`` to send (urgent channel first, then in the order they were numbered) and
    ``events`` to read, in the order they happened. False when both are empty."""

    packets: list[Outgoing] = field(default_factory=list)
    events: list[CoreEvent] = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.packets or self.events)


class Collector:
    """The output of one platform (``sender``) of swarm ``swarm`` in ``incarnation``.

    The parts append; the host takes. ``seq`` is the last packet sequence given out;
    ``queued`` holds (destination, body, channel) packets not numbered yet.
    """

    __slots__ = ("events", "failures", "incarnation", "packets", "queued", "sender", "seq", "swarm")

    def __init__(self, *, swarm: str = "swarm", sender: int = 0, incarnation: int = 0) -> None:
        self.swarm = swarm
        self.sender = sender
        self.incarnation = incarnation
        self.seq = 0
        self.packets: list[Outgoing] = []
        self.queued: list[tuple[int | None, wire.Body, int]] = []
        self.events: list[CoreEvent] = []
        self.failures: list[DeliveryFailure] = []

    @property
    def pending(self) -> bool:
        """Whether packets or events wait to be taken (failures not reported yet do not
        count: they become events at the node's next report)."""
        return bool(self.packets or self.events or self.queued)

    def queue(self, dst: int | None, body: wire.Body, channel: int) -> None:
        """A stream's or the board's packet: numbered at the next :meth:`send` or take."""
        self.queued.append((dst, body, channel))

    def send(self, dst: int | None, body: wire.Body, channel: int, kind: str | None = None) -> None:
        """Number and encode ``body`` now, after everything queued before it (``kind``:
        another label than the body's type, :class:`Outgoing`)."""
        if self.queued:
            self.number_queued()
        self.encode(dst, body, channel, kind)

    def number_queued(self, channel: int | None = None) -> None:
        """Number and encode the queued packets, in order (on ``channel`` if given, else
        each on its own)."""
        queued = self.queued
        self.queued = []
        for dst, body, own in queued:
            self.encode(dst, body, own if channel is None else channel)

    def encode(
        self, dst: int | None, body: wire.Body, channel: int, kind: str | None = None
    ) -> None:
        """Number ``body`` with the next packet sequence and append it, ahead of anything
        still queued (:meth:`send` is what keeps the order; an endpoint that numbers its
        streams last, like the ground station, calls this)."""
        self.seq += 1
        data = wire.encode(
            swarm=self.swarm,
            sender=self.sender,
            incarnation=self.incarnation,
            seq=self.seq,
            body=body,
        )
        self.packets.append(Outgoing(dst, data, kind or type(body).__name__, channel))

    def take(self) -> Ready:
        """Everything produced so far, queued packets numbered now: the packets urgent
        channel first, then in order; the events in the order they happened. The collector
        is empty afterwards. The only way anything leaves it."""
        if self.queued:
            self.number_queued()
        packets, events = self.packets, self.events
        self.packets, self.events = [], []
        if any(o.channel == URGENT for o in packets):
            packets.sort(key=lambda o: o.channel)  # stable: the order within a channel is kept
        return Ready(packets, events)
