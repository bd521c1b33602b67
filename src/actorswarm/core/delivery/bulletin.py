"""Bulletins: one message from the master to every member, as one broadcast.

Theory of operation
-------------------
The master tells every member the same thing after each collective switch (an event to
relay, what it runs now). Sent over the per-member reliable streams that costs N − 1
unicasts per message; a bulletin is *one* broadcast instead, acknowledged by each member and
retransmitted only to those that did not acknowledge (as barrier releases are): one packet
to the few when few are missing, one broadcast naming them when many are.

The master numbers its bulletins 1, 2, … (per incarnation). Each is addressed to the members
of its view when posted (``targets``) minus the ones it names in ``skip`` (an event's
origin, which handled it already). Every packet carries ``floor``, the lowest number the
master still holds, so a member never waits for a bulletin that was given up or not meant
for it.

A member follows only the bulletins of the master it follows: on a new master (or a new
incarnation of it) it starts afresh. The master's handshake ``Sync`` tells it the first
bulletin it is a target of (the next one when it joined the view or the master claimed);
until then it starts at the floor of the first bulletin it hears. It delivers in order,
exactly once; one that arrives early waits in a bounded buffer until the gap is filled or the
floor passes it; one whose ``skip`` names it fills its gap without being delivered; a
retransmission that names others only is ignored (its name may be in another chunk). Its
acknowledgement is cumulative.

A bulletin still unacknowledged by a target at its deadline is given up and reported as a
:class:`~actorswarm.core.ready.DeliveryFailure`, like any reliable message; a target that
leaves the view is dropped from it.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from dataclasses import dataclass, field

from actorswarm.core.config import CoreConfig
from actorswarm.core.ready import Collector, DeliveryFailure
from actorswarm.core.wire import NORMAL, AppMessage, Bulletin, BulletinAck

#: Above this many unacknowledged targets a retransmission is one broadcast naming them
#: (split in ``release_chunk`` names per packet); at or below it, one unicast each.
UNICAST_AT_MOST = 4


@dataclass(slots=True)
class _Posted:
    seq: int
    message: AppMessage
    skip: list[int]
    unacked: set[int]
    deadline: float
    due: float
    retries: int = 0


@dataclass(slots=True)
class BulletinBoard:
    """The master's side: bulletins in flight. Sans-IO: packets are queued in collector
    ``output`` (destination None for a broadcast, numbered in order with the streams'),
    bulletins given up go to its ``failures``."""

    config: CoreConfig
    output: Collector = field(default_factory=Collector)
    next_seq: int = 1
    posted: dict[int, _Posted] = field(default_factory=dict)
    _timers: list[tuple[float, int]] = field(default_factory=list)
    #: The wait before a bulletin's next retransmission after k, from the first (the node
    #: plugs in its reliable layer's, which paces a shared channel).
    #: Called with the retries so far, the first retry's delay and how many members the
    #: retransmission asks to acknowledge.
    retry_delay: Callable[[int, float, int], float] | None = None

    def _delay(self, retries: int, first_retry: float, answers: int) -> float:
        if self.retry_delay is None:
            return self.config.retry_delay(retries, first_retry)
        return self.retry_delay(retries, first_retry, answers)

    @property
    def floor(self) -> int:
        return min(self.posted, default=self.next_seq)

    def post(
        self,
        message: AppMessage,
        targets: set[int],
        now: float,
        epoch: int,
        first_retry: float,
        *,
        skip: tuple[int, ...] = (),
    ) -> None:
        """Broadcast ``message`` to ``targets`` (minus ``skip``); retransmit until each
        acknowledges, leaves or the delivery deadline passes."""
        seq = self.next_seq
        self.next_seq += 1
        unacked = set(targets) - set(skip)
        item = _Posted(
            seq=seq,
            message=message,
            skip=sorted(skip),
            unacked=unacked,
            deadline=now + self.config.delivery_deadline,
            due=now + self._delay(0, first_retry, len(unacked)),
        )
        if unacked:
            self.posted[seq] = item
            heapq.heappush(self._timers, (min(item.due, item.deadline), seq))
        self.output.queue(None, self._packet(item, epoch, None), NORMAL)

    def _packet(self, item: _Posted, epoch: int, to: list[int] | None) -> Bulletin:
        return Bulletin(
            epoch=epoch,
            seq=item.seq,
            floor=self.floor,
            message=item.message,
            skip=item.skip,
            to=to,
        )

    def on_ack(self, sender: int, ack: BulletinAck) -> None:
        """``sender`` has every bulletin up to ``ack.seq``."""
        for seq in [s for s in self.posted if s <= ack.seq]:
            item = self.posted[seq]
            item.unacked.discard(sender)
            if not item.unacked:
                del self.posted[seq]

    def clear(self, reason: str) -> None:
        """Give up every bulletin in flight (this platform is master no more)."""
        for item in self.posted.values():
            self.output.failures.extend(
                DeliveryFailure(p, item.message, reason) for p in sorted(item.unacked)
            )
        self.posted.clear()
        self._timers.clear()

    def member_left(self, platform: int) -> None:
        """``platform`` left the view: nobody waits for its acknowledgements any more."""
        for seq in list(self.posted):
            item = self.posted[seq]
            item.unacked.discard(platform)
            if not item.unacked:
                del self.posted[seq]

    def tick(self, now: float, epoch: int, first_retry: float) -> None:
        """Retransmit what is due; give up what passed its deadline."""
        timers = self._timers
        while timers and timers[0][0] <= now:
            _, seq = heapq.heappop(timers)
            item = self.posted.get(seq)
            if item is None:
                continue
            if now >= item.deadline:
                del self.posted[seq]
                self.output.failures.extend(
                    DeliveryFailure(p, item.message) for p in sorted(item.unacked)
                )
                continue
            if item.due > now:
                heapq.heappush(timers, (min(item.due, item.deadline), seq))
                continue
            item.retries += 1
            item.due = now + self._delay(item.retries, first_retry, len(item.unacked))
            heapq.heappush(timers, (min(item.due, item.deadline), seq))
            missing = sorted(item.unacked)
            if len(missing) <= UNICAST_AT_MOST:
                for platform in missing:
                    self.output.queue(platform, self._packet(item, epoch, [platform]), NORMAL)
            else:
                chunk = self.config.release_chunk
                for start in range(0, len(missing), chunk):
                    to = missing[start : start + chunk]
                    self.output.queue(None, self._packet(item, epoch, to), NORMAL)

    def next_deadline(self) -> float | None:
        return self._timers[0][0] if self._timers else None


@dataclass(slots=True)
class BulletinInbox:
    """A member's side: the bulletins of the master it follows, delivered in order."""

    platform: int
    window: int = 256
    master: int | None = None
    incarnation: int = -1  # the master's, learnt from its first bulletin
    expected: int = 0  # 0: nothing heard yet
    start_at: int = 0  # the first bulletin it is a target of, when the master said
    buffer: dict[int, Bulletin] = field(default_factory=dict)

    def follow(self, master: int | None) -> None:
        """Start afresh with a new master (None: none)."""
        if master != self.master:
            self.master = master
            self.start_at = 0
            self._reset(-1)

    def _reset(self, incarnation: int) -> None:
        if self.incarnation >= 0:
            self.start_at = 0  # the master rebooted: its numbering starts again
        self.incarnation = incarnation
        self.expected = 0
        self.buffer.clear()

    def start(self, seq: int) -> list[Bulletin]:
        """The master says this platform is a target from bulletin ``seq`` on (its handshake
        ``Sync``): nothing below it is waited for. Returns what is deliverable now."""
        self.start_at = max(self.start_at, seq)
        if self.expected and self.expected < seq:
            self.expected = seq
            for old in [s for s in self.buffer if s < seq]:
                del self.buffer[old]
            return self._drain()
        return []

    def _drain(self) -> list[Bulletin]:
        delivered = []
        while self.expected in self.buffer:
            item = self.buffer.pop(self.expected)
            self.expected += 1
            if self.platform not in item.skip:
                delivered.append(item)
        return delivered

    def on_bulletin(
        self, sender: int, incarnation: int, bulletin: Bulletin
    ) -> tuple[list[Bulletin], BulletinAck | None]:
        """Accept one bulletin packet from ``sender``: what is deliverable now, in order (only
        those addressed to this platform), and the acknowledgement to send (None: ignored)."""
        if sender != self.master or incarnation < self.incarnation:
            return [], None
        if incarnation > self.incarnation:
            self._reset(incarnation)
        if bulletin.floor > bulletin.seq:
            return [], None  # malformed: the master never holds less than it sends
        if self.expected and bulletin.floor > self.expected:
            # Everything below the floor is settled without this platform: skip the gap.
            self.expected = bulletin.floor
            for seq in [s for s in self.buffer if s < bulletin.floor]:
                del self.buffer[seq]
        if bulletin.to is None or self.platform in bulletin.to:
            # (A retransmission naming others says nothing of whether this platform was a
            # target — its name may be in another chunk — so it fills no gap.)
            if self.expected == 0:
                # Anything the master still holds may be for this platform, unless its
                # handshake said where its part begins.
                self.expected = max(bulletin.floor, self.start_at)
            if 0 <= bulletin.seq - self.expected < self.window:
                self.buffer.setdefault(bulletin.seq, bulletin)
        if self.expected == 0:
            return [], None
        delivered = self._drain()
        ack = BulletinAck(dst=sender, dst_incarnation=incarnation, seq=self.expected - 1)
        return delivered, ack
