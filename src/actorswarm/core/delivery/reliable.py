"""Reliable, ordered, exactly-once delivery over a lossy, duplicating, reordering radio.

Theory of operation
-------------------
Each (destination, channel) has an :class:`OutStream`: a queue of messages numbered 1, 2, …
The first ``window`` of them are in flight; each is retransmitted until the destination
acknowledges it, the delay growing linearly (``retry_base + k * retry_step``, capped at
``retry_cap``) so a congested radio is not flooded. A message that is still unacknowledged at
its deadline is dropped and reported (:class:`~actorswarm.core.ready.DeliveryFailure`) —
never silently lost.

Every data packet carries ``floor``, the lowest sequence its sender still holds. A receiver
never waits for anything below the floor, which makes abandoned messages, a receiver that
rebooted, and a sender that dropped a queue all harmless to the order of what follows.

Receivers keep an :class:`InStream` per (sender, channel) for the sender's current
incarnation: messages below the next expected sequence are duplicates (acknowledged again,
not delivered), messages above it wait in a bounded buffer until the gap is filled, and the
acknowledgement is cumulative. A new sender incarnation resets the stream; an older one is
ignored.

Master-bound messages travel on a stream of their own (channel
:data:`~actorswarm.core.wire.TO_MASTER`) whose destination is "the master": they wait while
there is none and follow every change of master (:meth:`Reliable.retarget`) keeping their
sequence numbers. A master that already delivered one recognises the re-sent copy as a
duplicate, so re-targeting never makes a message reach an application twice.

Channel :data:`~actorswarm.core.wire.URGENT` (ground-station traffic) is always transmitted
before :data:`~actorswarm.core.wire.NORMAL`.
"""

from __future__ import annotations

import heapq
from collections import deque
from dataclasses import dataclass, field

from actorswarm.core.config import CoreConfig
from actorswarm.core.delivery.rtt import RttEstimator
from actorswarm.core.ready import Collector, DeliveryFailure
from actorswarm.core.wire import NORMAL, TO_MASTER, URGENT, Ack, Data, Payload

#: Key of the master-bound stream in the stream table (no platform has ID -1).
_MASTER_KEY = (-1, TO_MASTER)

#: The fewest answers a retransmission's wait allows channel time for
#: (:meth:`Reliable.retry_delay`): the swarm's heartbeats and other traffic are on the air
#: too.
ANSWERS_FLOOR = 16


@dataclass(slots=True)
class _Item:
    seq: int
    payload: Payload
    deadline: float
    epoch: int  # the sender's epoch when queued: a decision is never re-dated
    retries: int = 0
    sent_at: float = 0.0  # first transmission, for round-trip samples
    due: float = 0.0
    sent: bool = False
    last: float = 0.0  # latest transmission (a hurried copy included)


@dataclass(slots=True)
class OutStream:
    """Messages from this platform to one destination on one channel.

    ``dst`` is None for the master-bound stream while there is no (remote) master.
    """

    dst: int | None
    channel: int
    next_seq: int = 1
    items: deque[_Item] = field(default_factory=deque)

    @property
    def floor(self) -> int:
        return self.items[0].seq if self.items else self.next_seq


@dataclass(slots=True)
class InStream:
    """What this platform has delivered from one sender incarnation on one channel."""

    incarnation: int
    expected: int = 0  # 0: nothing received yet; initialised from the first floor
    buffer: dict[int, tuple[int, Payload]] = field(default_factory=dict)  # seq -> (epoch, ...)


class Reliable:
    """All reliable streams of one platform. Sans-IO: data packets to send are queued in
    collector ``output`` (unnumbered: :meth:`~actorswarm.core.ready.Collector.queue`), messages
    given up go to its ``failures``; without one it keeps a collector of its own."""

    def __init__(self, config: CoreConfig, output: Collector | None = None) -> None:
        self._config = config
        self._out: dict[tuple[int, int], OutStream] = {}
        self._in: dict[tuple[int, int], InStream] = {}
        # (due, stream key dst, stream key channel, seq); stale entries are skipped
        self._timers: list[tuple[float, int, int, int]] = []
        self._master_stream = OutStream(None, TO_MASTER)
        self._rtt: dict[int, RttEstimator] = {}
        #: Round trips to anyone: the estimate for broadcasts (barrier releases).
        self.overall = self._new_estimator()
        self._out[_MASTER_KEY] = self._master_stream
        self.output = output if output is not None else Collector()
        #: On a shared channel (``channel_bitrate``), the time the swarm takes to put one
        #: packet each on the air, set by the platform from its view (0: no channel).
        self.channel_time = 0.0
        #: The swarm's size behind :attr:`channel_time` (1 without a channel).
        self.channel_size = 1

    # --- sending ---------------------------------------------------------------------

    def send(
        self,
        dst: int,
        payload: Payload,
        now: float,
        epoch: int,
        *,
        channel: int = NORMAL,
    ) -> None:
        """Queue ``payload`` for ``dst``; transmit at once if the window has room."""
        stream = self._out.get((dst, channel))
        if stream is None:
            stream = self._out[(dst, channel)] = OutStream(dst, channel)
        self._enqueue(stream, payload, now, epoch)

    def send_to_master(self, payload: Payload, now: float, epoch: int, *, copies: int = 1) -> int:
        """Queue a master-bound message; it waits while there is no master (see retarget).
        ``copies`` > 1 sends its first transmission that many times over (each copy may be
        lost on its own; the first that arrives is delivered, the rest are duplicates).
        Returns its sequence number on the master-bound stream."""
        stream = self._master_stream
        self._enqueue(stream, payload, now, epoch)
        item = stream.items[-1]
        if stream.dst is not None and item.sent:
            for _ in range(copies - 1):
                self._queue_copy(stream, stream.dst, item, now)
        return stream.next_seq - 1

    def master_holds(self, seq: int) -> bool:
        """Whether master-bound message ``seq`` is still waiting for its acknowledgement
        (False once acknowledged, dropped at its deadline or as stale)."""
        items = self._master_stream.items
        return bool(items) and items[0].seq <= seq and any(i.seq == seq for i in items)

    def _enqueue(self, stream: OutStream, payload: Payload, now: float, epoch: int) -> None:
        item = _Item(
            seq=stream.next_seq,
            payload=payload,
            deadline=now + self._config.delivery_deadline,
            epoch=epoch,
        )
        stream.next_seq += 1
        stream.items.append(item)
        if len(stream.items) <= self._config.window:
            self._transmit(stream, item, now)

    def _new_estimator(self) -> RttEstimator:
        c = self._config
        return RttEstimator(initial=c.retry_base, floor=c.retry_min, cap=c.retry_cap)

    def _estimator(self, dst: int) -> RttEstimator:
        est = self._rtt.get(dst)
        if est is None:
            est = self._rtt[dst] = self._new_estimator()
        return est

    def timeout(self, dst: int | None) -> float:
        """First retransmission delay towards ``dst`` (None: anyone), from measured round
        trips when ``adaptive_retry`` is on."""
        if not self._config.adaptive_retry:
            return self._config.retry_base
        est = self._rtt.get(dst) if dst is not None else None
        if est is None or est.srtt is None:
            est = self.overall
        return est.timeout

    def retry_delay(
        self, retries: int, base: float | None = None, answers: int | None = None
    ) -> float:
        """The wait before the next retransmission after ``retries`` earlier ones, the
        first being ``base`` (default ``retry_base``): linear (:meth:`CoreConfig.retry_delay`);
        on a shared channel doubling with each retry from at least twice
        :attr:`channel_time` up to four times it (or ``retry_cap``, if longer). An
        acknowledgement cannot come back before the packets queued ahead of it, and those
        queued ahead of the acknowledgement, are on the air, and a retry that finds the
        channel full only adds to what it waits behind (a claim sets off a report from every
        member at once, a release to all an acknowledgement from each); with every member
        retrying at most once per four channel times, retries take at most a quarter of the
        channel. (Doubling without that cap left a barrier request lost twice at 10 % loss
        waiting 11 s among 1000 platforms.) Releases and bulletins use it too.

        ``answers``: how many platforms the retransmission asks to acknowledge, when known
        (a release or bulletin resent to the members that have not acknowledged it): the
        channel time is then theirs, not the whole swarm's, so that the last few members of
        a release of 1000 are not retried at the pace its first burst needed. At least
        :data:`ANSWERS_FLOOR`, for the swarm's own traffic they queue behind."""
        delay = self._config.retry_delay(retries, base)
        slot = self.channel_time
        if slot <= 0.0:
            return delay
        if answers is not None and answers < self.channel_size:
            slot *= max(answers, ANSWERS_FLOOR) / self.channel_size
        first = max(2 * slot, self._config.retry_base if base is None else base)
        cap = max(4 * slot, self._config.retry_cap)
        return max(delay, min(first * (1 << min(retries, 4)), cap))

    def _retry_delay(self, retries: int, dst: int | None) -> float:
        return self.retry_delay(retries, self.timeout(dst))

    def _key(self, stream: OutStream) -> tuple[int, int]:
        if stream is self._master_stream or stream.dst is None:
            return _MASTER_KEY
        return (stream.dst, stream.channel)

    @property
    def master(self) -> int | None:
        """Where master-bound messages go now (None: they wait)."""
        return self._master_stream.dst

    def _transmit(self, stream: OutStream, item: _Item, now: float) -> None:
        key = self._key(stream)
        if stream.dst is None:
            # Nowhere to send it yet: only its deadline can fire.
            item.sent = False
            heapq.heappush(self._timers, (item.deadline, key[0], key[1], item.seq))
            return
        self._queue_copy(stream, stream.dst, item, now)
        if item.sent:
            item.retries += 1  # this transmission is a retry: the next wait grows
        else:
            item.sent_at = now
        item.due = now + self._retry_delay(item.retries, stream.dst)
        item.sent = True
        heapq.heappush(self._timers, (min(item.due, item.deadline), key[0], key[1], item.seq))

    def _queue_copy(self, stream: OutStream, dst: int, item: _Item, now: float) -> None:
        self.output.queue(
            dst,
            Data(
                dst=dst,
                channel=stream.channel,
                seq=item.seq,
                floor=stream.floor,
                epoch=item.epoch,
                payload=item.payload,
            ),
            stream.channel,
        )
        item.last = now

    def hurry_master(self, now: float, spacing: float) -> int:
        """The master says it still waits for something of mine (it lists me as awaited):
        send every master-bound message it has not acknowledged again now, unless its
        latest copy went out less than ``spacing`` ago. The retry schedule is left as it
        was (a hurried copy is not a retry). Returns how many copies went out."""
        stream = self._master_stream
        dst = stream.dst
        if dst is None:
            return 0
        sent = 0
        for item in stream.items:
            if item.sent and now - item.last >= spacing:
                self._queue_copy(stream, dst, item, now)
                sent += 1
        return sent

    def retarget(
        self,
        master: int | None,
        now: float,
        epoch: int | None = None,
        stale: tuple[type, ...] = (),
    ) -> None:
        """The master changed: master-bound messages go to ``master`` from now on, in order.

        ``master=None`` means "no remote master" (none known, or this platform is the master):
        the messages wait, and a master takes them with :meth:`take_unrouted`. ``epoch``:
        the new master's; messages of the types ``stale`` names that are stamped with an
        older one are dropped here (a master ignores them, and the report that follows
        restates what they asked), so they do not hold up the stream for the ones that count.
        """
        stream = self._master_stream
        if stream.dst == master:
            return
        stream.dst = master
        if epoch is not None:
            stream.items = deque(
                item
                for item in stream.items
                if item.epoch >= epoch or not isinstance(item.payload, stale)
            )
        for item in stream.items:
            item.retries = 0
            item.sent = False
        self._refill(stream, now)

    def take_unrouted(self) -> list[Payload]:
        """Hand over every waiting master-bound message (this platform is the master now)."""
        stream = self._master_stream
        payloads = [item.payload for item in stream.items]
        stream.items.clear()
        return payloads

    def drop_destination(self, dst: int, now: float) -> None:
        """``dst`` left the swarm: drop its queues; master-bound messages wait for a master."""
        for channel in (URGENT, NORMAL):
            stream = self._out.get((dst, channel))
            if stream is not None and stream.items:
                self.output.failures.extend(
                    DeliveryFailure(dst, item.payload, "left") for item in stream.items
                )
                # Keep the numbering so a returning peer never confuses old and new.
                self._out[(dst, channel)] = OutStream(dst, channel, next_seq=stream.next_seq)
        if self._master_stream.dst == dst:
            self.retarget(None, now)

    def forget_sender(self, sender: int, incarnation: int) -> None:
        """``sender`` rebooted out of ``incarnation``: forget what it sent in that one (or
        before). A stream of its new incarnation is kept: its first messages may have arrived
        before its heartbeat showed the reboot, and forgetting them would deliver their
        retransmissions twice."""
        for channel in (URGENT, NORMAL, TO_MASTER):
            stream = self._in.get((sender, channel))
            if stream is not None and stream.incarnation <= incarnation:
                del self._in[(sender, channel)]

    def on_ack(self, sender: int, ack: Ack, now: float) -> None:
        """Remove everything ``sender`` acknowledged cumulatively; fill the window."""
        if ack.channel == TO_MASTER:
            stream: OutStream | None = self._master_stream
            if self._master_stream.dst != sender:
                return
        else:
            stream = self._out.get((sender, ack.channel))
        if stream is None:
            return
        items = stream.items
        changed = False
        sampled: _Item | None = None
        while items and items[0].seq <= ack.seq:
            item = items.popleft()
            if item.sent and item.retries == 0:
                sampled = item  # Karn: only a message sent once gives a clean sample
            changed = True
        if sampled is not None and self._config.adaptive_retry:
            rtt = now - sampled.sent_at
            self._estimator(sender).sample(rtt)
            self.overall.sample(rtt)
        if changed:
            self._refill(stream, now)

    def _refill(self, stream: OutStream, now: float) -> None:
        for i, item in enumerate(stream.items):
            if i >= self._config.window:
                break
            if not item.sent:
                self._transmit(stream, item, now)

    def on_data(
        self, sender: int, incarnation: int, data: Data
    ) -> tuple[list[tuple[int, Payload]], Ack | None]:
        """Accept one data packet; return what is now deliverable, in order, as (epoch the
        sender stamped it with, payload), and the acknowledgement to send."""
        key = (sender, data.channel)
        stream = self._in.get(key)
        if stream is None or incarnation > stream.incarnation:
            stream = self._in[key] = InStream(incarnation)
        elif incarnation < stream.incarnation:
            return [], None
        if data.floor > data.seq:
            return [], None  # malformed: a sender never holds less than what it sends
        if stream.expected == 0:
            stream.expected = data.floor
        elif data.floor > stream.expected:
            # The sender abandoned everything below its floor: skip the gap.
            stream.expected = data.floor
            for seq in [s for s in stream.buffer if s < data.floor]:
                del stream.buffer[seq]
        delivered: list[tuple[int, Payload]] = []
        if data.seq == stream.expected:
            delivered.append((data.epoch, data.payload))
            stream.expected += 1
        elif data.seq > stream.expected and data.seq - stream.expected < 4 * self._config.window:
            stream.buffer[data.seq] = (data.epoch, data.payload)
        # Whatever waited for the gap just filled (or skipped) is deliverable now.
        while stream.expected in stream.buffer:
            delivered.append(stream.buffer.pop(stream.expected))
            stream.expected += 1
        ack = Ack(
            dst=sender, dst_incarnation=incarnation, channel=data.channel, seq=stream.expected - 1
        )
        return delivered, ack

    # --- time ------------------------------------------------------------------------

    def tick(self, now: float) -> None:
        """Retransmit what is due; fail what passed its deadline."""
        timers = self._timers
        while timers and timers[0][0] <= now:
            _, dst, channel, seq = heapq.heappop(timers)
            stream = self._out.get((dst, channel))
            if stream is None or not stream.items or seq < stream.items[0].seq:
                continue
            index = seq - stream.items[0].seq
            if index >= len(stream.items) or stream.items[index].seq != seq:
                # A message in the middle failed earlier, so numbering has a gap: search.
                found = next((i for i, it in enumerate(stream.items) if it.seq == seq), None)
                if found is None:
                    continue
                index = found
            item = stream.items[index]
            if now >= item.deadline:
                del stream.items[index]
                self.output.failures.append(DeliveryFailure(stream.dst, item.payload))
                self._refill(stream, now)
            elif item.sent and item.due <= now:
                self._transmit(stream, item, now)

    def next_deadline(self) -> float | None:
        """Earliest time :meth:`tick` has something to do."""
        return self._timers[0][0] if self._timers else None

    def pending(self, dst: int) -> int:
        """How many messages to ``dst`` are not yet acknowledged (both channels)."""
        return sum(len(s.items) for (d, _), s in self._out.items() if d == dst)
