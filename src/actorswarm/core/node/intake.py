"""What arrives at a node, past the checks of :meth:`Node.receive_packet
<actorswarm.core.node.coordinator.Node.receive_packet>`: one handler per body type
(:data:`_BODY_HANDLERS`; heartbeats go to :class:`~.liveness.Liveness`), and the messages
the reliable streams and bulletins deliver in order, each to the part it is for — the
application, the leadership (a master's Sync), the role (master-bound messages, releases).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Final

from actorswarm.core.events import AppReceived
from actorswarm.core.node.leadership import MASTER_BOUND, Leadership
from actorswarm.core.wire import (
    BULLETIN_STREAM,
    NORMAL,
    URGENT,
    Ack,
    AppMessage,
    Bulletin,
    BulletinAck,
    Data,
    Packet,
    Payload,
    Release,
    ReleaseAck,
    RosterChunk,
    RosterRequest,
    Sync,
)

if TYPE_CHECKING:
    from actorswarm.core.delivery.bulletin import BulletinBoard, BulletinInbox
    from actorswarm.core.node.coordinator import Node
    from actorswarm.core.node.duties import MemberDuties
    from actorswarm.core.node.rostersync import RosterSync
    from actorswarm.core.ready import Collector


class Intake:
    """The packet handlers of one :class:`~actorswarm.core.node.coordinator.Node`."""

    def __init__(
        self,
        node: Node,
        out: Collector,
        board: BulletinBoard,
        inbox: BulletinInbox,
        *,
        lead: Leadership,
        rosters: RosterSync,
        member: MemberDuties,
    ) -> None:
        self._node = node
        # Where a body goes besides the node's role: a Sync to the leadership, a roster
        # chunk to the roster sync, the master's replies to the member's side.
        self._lead = lead
        self._rosters = rosters
        self._member = member
        self._board = board  # the node's bulletin board (master to every member)
        self._inbox = inbox  # the node's bulletin inbox (from the master it follows)
        self._out = out  # the node's collector: what this part sends and reports

    def deliver_bulletins(self, sender: int, incarnation: int, items: list[Bulletin]) -> None:
        for item in items:
            self._out.events.append(
                AppReceived(
                    sender=sender,
                    topic=item.message.topic,
                    body=item.message.body,
                    stream=(incarnation, BULLETIN_STREAM, item.seq),
                )
            )

    def _packet_data(self, packet: Packet, now: float) -> None:
        assert isinstance(packet.body, Data)
        self._on_data(packet.sender, packet.incarnation, packet.body, now)

    def _for_me(self, body: Ack | BulletinAck) -> bool:
        """Whether an acknowledgement is addressed to this incarnation of this platform
        (one that is not is counted as ``drop:not_for_me``)."""
        node = self._node
        if body.dst != node.platform or body.dst_incarnation != node.incarnation:
            node.counters["drop:not_for_me"] += 1
            return False
        return True

    def _packet_ack(self, packet: Packet, now: float) -> None:
        body = packet.body
        assert isinstance(body, Ack)
        if self._for_me(body):
            self._node.reliable.on_ack(packet.sender, body, now)

    def _packet_release(self, packet: Packet, now: float) -> None:
        node = self._node
        assert isinstance(packet.body, Release)
        node._role.on_release(packet.sender, packet.body, now)

    def _packet_roster_request(self, packet: Packet, now: float) -> None:
        node = self._node
        body = packet.body
        assert isinstance(body, RosterRequest)
        node._role.on_roster_request(packet.sender, body)

    def _packet_roster_chunk(self, packet: Packet, now: float) -> None:
        assert isinstance(packet.body, RosterChunk)
        self._rosters.on_chunk(packet.sender, packet.body, now)

    def _packet_bulletin(self, packet: Packet, now: float) -> None:
        assert isinstance(packet.body, Bulletin)
        self._on_bulletin(packet.sender, packet.incarnation, packet.body, now)

    def _packet_bulletin_ack(self, packet: Packet, now: float) -> None:
        body = packet.body
        assert isinstance(body, BulletinAck)
        if self._for_me(body):
            self._board.on_ack(packet.sender, body)

    def _packet_release_ack(self, packet: Packet, now: float) -> None:
        node = self._node
        body = packet.body
        assert isinstance(body, ReleaseAck)
        node._role.on_release_ack(packet.sender, body)

    def _on_bulletin(self, sender: int, incarnation: int, bulletin: Bulletin, now: float) -> None:
        node = self._node
        delivered, ack = self._inbox.on_bulletin(sender, incarnation, bulletin)
        if ack is None:
            node.counters["drop:bulletin"] += 1
            return
        self._out.send(sender, ack, NORMAL)
        self.deliver_bulletins(sender, incarnation, delivered)

    def _on_data(self, sender: int, incarnation: int, data: Data, now: float) -> None:
        node = self._node
        if data.dst != node.platform:
            node.counters["drop:not_for_me"] += 1
            return
        delivered, ack = node.reliable.on_data(sender, incarnation, data)
        if ack is not None:
            self._out.send(sender, ack, URGENT if data.channel == URGENT else NORMAL)
        first = ack.seq - len(delivered) + 1 if ack is not None else 0
        for i, (epoch, payload) in enumerate(delivered):
            self._on_payload(sender, epoch, payload, now, (incarnation, data.channel, first + i))

    def _on_payload(
        self,
        sender: int,
        epoch: int,
        payload: Payload,
        now: float,
        stream: tuple[int, int, int] | None = None,
    ) -> None:
        """One message delivered in order, exactly once, from ``sender``'s stream."""
        node = self._node
        if isinstance(payload, AppMessage):
            self._out.events.append(
                AppReceived(sender=sender, topic=payload.topic, body=payload.body, stream=stream)
            )
        elif isinstance(payload, Sync):
            self._lead.on_sync(sender, payload, now, -1 if stream is None else stream[0])
        elif isinstance(payload, MASTER_BOUND):
            node._role.on_master_bound(sender, epoch, payload, now)
        elif sender != node.master or epoch != node.epoch:
            node.counters["drop:stale_epoch"] += 1
        else:
            self._member.take(payload, now)


#: What a received packet's body is handed to (heartbeats are taken first, in
#: :meth:`~actorswarm.core.node.coordinator.Node._dispatch`); the wire decoder produces no
#: other body type.
_BODY_HANDLERS: Final[dict[type[Any], Callable[[Intake, Packet, float], None]]] = {
    Data: Intake._packet_data,
    Ack: Intake._packet_ack,
    Release: Intake._packet_release,
    RosterRequest: Intake._packet_roster_request,
    RosterChunk: Intake._packet_roster_chunk,
    Bulletin: Intake._packet_bulletin,
    BulletinAck: Intake._packet_bulletin_ack,
    ReleaseAck: Intake._packet_release_ack,
}
