"""What the master's barrier and role tables decided, on its way to the node's collector.

The tables (:class:`~actorswarm.core.barrier.BarrierMaster`,
:class:`~actorswarm.core.roles.RoleMaster`) are given one :class:`MasterOutbox` at
construction, as their :class:`~actorswarm.core.barrier.BarrierOutput` and
:class:`~actorswarm.core.roles.RoleOutput`; the master's duties route what it holds
(:meth:`MasterDuties.flush <actorswarm.core.node.duties.MasterDuties.flush>`).

Why the decisions wait here instead of going out as they are made: where they land is the
order the swarm sees, and that order is part of the protocol's behaviour (the packets'
sequence numbers, the events' order, the simulator's byte-identical replays). The node
routes them at fixed points of its step — after the view changes of that step (a member
that left may fire a barrier of all, reported after every change of the view and the
messages given up with it), after a master-bound message, a tick, a change of needs, the
end of a handshake — and in this order, whatever order they were decided in: the firings,
then the stale notices, the role replies, the releases, and last the releases given up.
A notice or a reply goes over a reliable stream, queued, and a release is numbered after
everything queued before it, so a release decided before a notice still follows it.
"""

from __future__ import annotations

from typing import Final, NamedTuple

from actorswarm.core.events import BarrierFired, DeliveryFailed
from actorswarm.core.roles import Reply
from actorswarm.core.wire import BarrierStale, Payload, Release


class ToMember(NamedTuple):
    """A message from the master to one member (a stale notice, a role's reply)."""

    platform: int
    payload: Payload


#: What the outbox hands over: an event to report, a message to a member, a release.
Decision = BarrierFired | DeliveryFailed | ToMember | Release

# The order in which the node routes what was decided since its last flush.
_FIRED: Final = 0
_STALE: Final = 1
_REPLY: Final = 2
_RELEASE: Final = 3
_GAVE_UP: Final = 4


class MasterOutbox:
    """One ordered queue of what the master's tables decided (see the module)."""

    __slots__ = ("_queue",)

    def __init__(self) -> None:
        self._queue: list[tuple[int, Decision]] = []

    def fired(self, event: BarrierFired) -> None:
        self._queue.append((_FIRED, event))

    def stale(self, platform: int, notice: BarrierStale) -> None:
        self._queue.append((_STALE, ToMember(platform, notice)))

    def reply(self, platform: int, reply: Reply) -> None:
        self._queue.append((_REPLY, ToMember(platform, reply)))

    def release(self, packet: Release) -> None:
        self._queue.append((_RELEASE, packet))

    def gave_up(self, key: int, generation: int, unacked: set[int]) -> None:
        failed = DeliveryFailed(
            dst=None,
            kind="Release",
            reason=f"barrier {key}/{generation}: no acknowledgement from {sorted(unacked)}",
        )
        self._queue.append((_GAVE_UP, failed))

    def take(self) -> list[Decision]:
        """Everything decided since the last take, in the order to route it (decisions of
        one kind in the order they were made); the outbox is empty afterwards."""
        queue, self._queue = self._queue, []
        queue.sort(key=lambda item: item[0])  # stable: the order within a kind is kept
        return [decision for _, decision in queue]


__all__ = ["Decision", "MasterOutbox", "ToMember"]
