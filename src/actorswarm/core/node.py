"""One platform's collective core: the sans-IO object every host drives.

Theory of operation
-------------------
A host (the simulator, the daemon) owns a :class:`Node` and does three things with it:

* hands it every packet that arrives — :meth:`Node.receive` for untrusted bytes, or
  :meth:`Node.receive_packet` for a packet already decoded once for many receivers;
* calls :meth:`Node.tick` no later than :meth:`Node.next_deadline`;
* after each of these (and each application call) takes :meth:`Node.ready`: a
  :class:`~.ready.Ready` holding the packets to send (``dst`` None is a broadcast) and the
  events to read, everything at once. :attr:`Node.has_ready` says whether there is any.

The application (task engine, tests) asks for coordination with :meth:`request_barrier`,
:meth:`claim_role`, :meth:`release_role` and :meth:`send_app`. Every call takes ``now``; the
node reads no clock, opens no socket, starts no thread and draws randomness only from the
seeded ``rng`` it was given (the phase of its heartbeats).

Inside, the node composes membership (:mod:`.membership`), election (:mod:`.election`),
reliable streams (:mod:`.reliable`), bulletins (:mod:`.bulletin`), barriers
(:mod:`.barrier`) and roles (:mod:`.roles`). Each part writes what it sends and reports
into the node's one collector (:mod:`.ready`). It is built in layers, one class per module:
:class:`~.node_base.NodeBase` (state and output), :class:`~.node_membership.NodeMembership`
(who is alive), :class:`~.node_election.NodeElection` (who is master, the handshake) and
:class:`Node` here (the host interface, packet dispatch, coordination messages).
Master-bound messages are sent to the current master — or handled in place when this platform
is the master — and wait, in order, while there is none. Packets that fail any check are
dropped and counted in :attr:`Node.counters`, never raised: untrusted bytes cannot crash a
platform nor change its state.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any, Final

from actorswarm.core import wire
from actorswarm.core.barrier import addressee
from actorswarm.core.events import (
    AppReceived,
    CoreEvent,
    DeliveryFailed,
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.node_base import (
    KEEP_ERRORS,
    MASTER_BOUND,
)
from actorswarm.core.node_election import NodeElection
from actorswarm.core.ready import Outgoing, Ready
from actorswarm.core.wire import (
    NORMAL,
    URGENT,
    Ack,
    AppMessage,
    BarrierRequest,
    BarrierStale,
    Bulletin,
    BulletinAck,
    Data,
    Heartbeat,
    Packet,
    Payload,
    Release,
    ReleaseAck,
    Report,
    RoleClaim,
    RoleDeny,
    RoleGrant,
    RoleRelease,
    RoleRevoke,
    RosterChunk,
    RosterRequest,
    Sync,
    WireError,
)


class Node(NodeElection):
    """The collective core of platform ``platform`` (1..65535) in its ``incarnation``."""

    def ready(self) -> Ready:
        """Everything to send and to read since the last call, taken at once: packets
        (ground-station channel first, then in the order they were numbered) and events (in
        the order they happened). The node holds no output afterwards."""
        return self._out.take()

    @property
    def has_ready(self) -> bool:
        """Whether :meth:`ready` would return anything.

        A host may skip :meth:`next_deadline` after a ``receive`` that left no output: a
        packet that makes the node send or report nothing never brings a deadline forward
        (at 1000 platforms this saves a call per heartbeat heard).
        """
        return self._out.pending

    def drain_outgoing(self) -> list[Outgoing]:
        """The packets of :meth:`ready` alone (the events stay for the next call): for
        endpoints that move packets only, like a security pipeline's."""
        return self._out.take_packets()

    def drain_events(self) -> list[CoreEvent]:
        """The events of :meth:`ready` alone (the packets stay for the next call)."""
        return self._out.take_events()

    def due(self, now: float) -> bool:
        """Whether a host awake at ``now`` should :meth:`tick`: a deadline has passed, or
        is within ``heartbeat_slack`` (a heartbeat then goes out on this wake instead of
        at a wake of its own; see :class:`~actorswarm.core.config.CoreConfig`)."""
        deadline = self.next_deadline()
        if deadline is not None and deadline <= now + (self.config.heartbeat_slack or 0.0):
            return True
        return now + self._heartbeat_window() >= self._next_heartbeat

    def next_deadline(self) -> float | None:
        """The latest time by which :meth:`tick` must be called next."""
        best = self._next_heartbeat
        members_due = self.members.next_deadline()
        for t in (
            None if members_due is None else members_due + self.grace,
            min(self._probe_due.values(), default=None),
            min(self._presumed.values(), default=None),
            self.reliable.next_deadline(),
            self._bmaster.next_deadline() if self.is_master else None,
            self._board.next_deadline() if self.is_master else None,
            self._handshake_deadline,
            self._sync_at,
        ):
            if t is not None and t < best:
                best = t
        if not self._awake:
            best = min(best, self._started + self.config.startup_wait)
        if self.master is not None and not self.is_master and self.master not in self.members:
            silent_until = self._master_heard + self.members.silence() + self._channel_patience()
            best = min(best, max(silent_until, self._master_hold))
        self._due = best
        return best

    def receive(self, data: bytes, now: float) -> None:
        """Accept untrusted bytes from the transport. Never raises."""
        try:
            packet = wire.decode(data, swarm=self.swarm, max_bytes=self.config.max_packet_bytes)
        except WireError as exc:
            self.counters[f"drop:{exc.reason}"] += 1
            return
        self.receive_packet(packet, now)

    def receive_batch(self, batch: list[bytes], now: float) -> None:
        """Accept several packets that arrived together: ground-station traffic (sender 0,
        the operator's commands) is processed before swarm traffic (docs/design.md §3.3)."""
        packets: list[Packet] = []
        for data in batch:
            try:
                packets.append(
                    wire.decode(data, swarm=self.swarm, max_bytes=self.config.max_packet_bytes)
                )
            except WireError as exc:
                self.counters[f"drop:{exc.reason}"] += 1
        packets.sort(key=lambda p: p.sender != wire.GROUND_STATION)  # stable: order kept
        for packet in packets:
            self.receive_packet(packet, now)

    def receive_packet(self, packet: Packet, now: float) -> None:
        """Accept a decoded packet. Never raises; a packet that fails a check is counted."""
        if packet.swarm != self.swarm:
            self.counters["drop:swarm"] += 1
            return
        if packet.sender == self.platform:
            self.counters["drop:own"] += 1
            return
        if not self.members.is_current(packet.sender, packet.incarnation):
            self.counters["drop:old_incarnation"] += 1
            return
        try:
            self._dispatch(packet, now)
        except Exception as exc:  # untrusted input must never take the platform down
            self.counters["drop:internal"] += 1
            if len(self.errors) < KEEP_ERRORS:
                self.errors.append(f"{type(exc).__name__}: {exc} (packet {packet!r})")

    def tick(self, now: float) -> None:
        """Advance timers to ``now``: leaves, elections, heartbeats, retransmissions."""
        if not self._awake and now >= self._started + self.config.startup_wait:
            self._awake = True  # listened long enough to know whether a master exists
        self._check_health(now)
        joined_left: list[MemberJoined | MemberLeft] = []
        suspected: list[int] = []
        self.members.expire(now, joined_left, suspected, self.grace)
        for peer in suspected:
            self.counters["suspected"] += 1
            if self._probes(peer):
                self._probe_due[peer] = now
        self._membership_changed(joined_left, now)
        self._probe(now)
        if self._master_unheard_since(now):
            self._lose_master(now)
        if self._presumed:
            self._presumed = {p: t for p, t in self._presumed.items() if t > now}
            if not self._presumed:
                self._listening_since = now
        self._maybe_claim(now)
        if self.is_master:
            if self._sync_at is not None and now >= self._sync_at:
                self._sync_at = None
                for peer in sorted(self._handshake_waiting):
                    sync = Sync(epoch=self.epoch, bulletin=self._claim_bulletin)
                    self.reliable.send(peer, sync, now, self.epoch)
            if self._handshake_deadline is not None and now >= self._handshake_deadline:
                self._finish_handshake(now)
            self._bmaster.tick(now, self.epoch)
            self._flush_master(now)
            self._board.tick(now, self.epoch, self.reliable.timeout(None))
        self.reliable.tick(now)
        self._report_failures()
        if self._restate:
            self._restate = False
            if self.master is not None and not self.is_master:
                self.counters["restated"] += 1
                self._report(now)
        if now + self._heartbeat_window() >= self._next_heartbeat:
            self._send_heartbeat(now)
            interval = self._own_interval()
            if self._rephase:  # after the boot heartbeat: a phase of its own, not its rank's
                self._rephase = False
                interval *= self._rng.uniform(0.5, 1.5)
            if self._rides_master() and now >= self._next_heartbeat:
                # A wake of its own: nothing it could ride on came within a slack of its
                # time. Half a slack later next time, towards the wakes its master's
                # heartbeats cause, until they come within the window; then it keeps that
                # phase (below), so the rate stays one per cadence however often it wakes.
                self._next_heartbeat += interval + (self.config.heartbeat_slack or 0.0) / 2
            else:
                # Sent early, on a tick the host made anyway: keep the phase, so the rate
                # stays one per interval.
                self._next_heartbeat += interval
            if self._next_heartbeat <= now:  # the host fell behind: do not burst
                self._next_heartbeat = now + interval

    def _rides_master(self) -> bool:
        """Whether this platform's heartbeats ride on its master's: a star member following
        a live master, with a heartbeat slack (a daemon)."""
        return bool(self.config.heartbeat_slack) and self._following_star()

    def _heartbeat_window(self) -> float:
        """How long before its time a heartbeat goes out on a wake the host makes anyway:
        the slack; or, for one that rides on its master's, two slacks before the time it
        goes out on a wake of its own, a window a slack either side of its phase: the
        master's heartbeats come up to a slack early (a busy master sends early on a wake
        it makes anyway) or late (a loaded host, a radio's jitter), and a window of one
        slack before lost them at every early one, waking twice per interval until the
        phase drifted back (see :meth:`tick`)."""
        slack = self.config.heartbeat_slack or 0.0
        return 2 * slack if self._rides_master() else slack

    def request_barrier(
        self,
        key: int,
        need: int | dict[int, int],
        now: float,
        *,
        part: int = 0,
        bid: float | None = None,
        data: Any = None,
        timeout: float | None = None,
        occasion: str = "",
        renew: bool = False,
    ) -> int:
        """Ask to pass barrier ``key``; returns the generation asked for.

        ``need`` is the number of participants (or :data:`~actorswarm.core.wire.NEED_ALL`),
        or a map part -> number for a barrier of several parts. The answer comes as a
        :class:`~actorswarm.core.events.BarrierReleased` (or ``BarrierStaleNotice``) event.
        ``renew``: this platform would ask again for the open generation if told the one
        it asks for is stale, so the master may count it for that one at once
        (:attr:`~actorswarm.core.wire.BarrierRequest.renew`); the release may then name a
        later generation than the one returned.
        """
        needs = {part: need} if isinstance(need, int) else dict(need)
        req = self.barriers.request(
            key,
            needs,
            now,
            part=part,
            bid=bid,
            data=data,
            timeout=timeout,
            epoch=self.epoch,
            occasion=occasion,
            master=self._epoch_master or 0,
            renew=renew,
        )
        self._to_master(req, now)
        return req.generation

    def claim_role(self, role: str, quota: int, now: float, *, bid: float | None = None) -> None:
        """Claim ``role`` (at most ``quota`` holders); answered by RoleGranted/RoleDenied."""
        claim = self.roles.claim(role, quota, float(self.platform if bid is None else bid))
        if role not in self.roles.held:
            self._to_master(claim, now)

    def release_role(self, role: str, now: float) -> None:
        if self.roles.release(role):
            self._to_master(RoleRelease(role=role), now)

    def send_app(
        self, dst: int | None, topic: str, body: bytes, now: float, *, urgent: bool = False
    ) -> None:
        """Send an application message reliably to ``dst`` (None: the master)."""
        msg = AppMessage(topic=topic, body=body)
        channel = URGENT if urgent else NORMAL
        if dst is None:
            if self.is_master:
                self._out.events.append(AppReceived(sender=self.platform, topic=topic, body=body))
            else:
                self.reliable.send_to_master(msg, now, self.epoch)
        elif dst == self.platform:
            self._out.events.append(AppReceived(sender=self.platform, topic=topic, body=body))
        else:
            self.reliable.send(dst, msg, now, self.epoch, channel=channel)

    def post_bulletin(
        self, topic: str, body: bytes, now: float, *, skip: tuple[int, ...] = ()
    ) -> None:
        """Master: send an application message to every member of the view but ``skip``,
        as one broadcast, retransmitted only to those that do not acknowledge (delivered in
        order, exactly once, as :class:`AppReceived`; not to this platform itself). A
        platform that is not master sends nothing."""
        if not self.is_master:
            self.counters["bulletin_not_master"] += 1
            return
        self._board.post(
            AppMessage(topic=topic, body=body),
            set(self.members.peers),
            now,
            self.epoch,
            self.reliable.timeout(None),
            skip=skip,
        )

    def needs_changed(self, now: float, keys: Iterable[int] | None = None) -> None:
        """Master: what the parts of barriers ``keys`` (None: all) wait for may have changed
        (the task engine learnt that a platform entered or left an actor): fire what is now
        complete."""
        if self.is_master:
            self._bmaster.needs_changed(now, self.epoch, keys)
            self._flush_master(now)

    def waiting_occasions(self, key: int) -> tuple[str, ...]:
        """Master: the occasions of the requests waiting at barrier ``key`` (none on a
        member)."""
        return self._bmaster.waiting_occasions(key) if self.is_master else ()

    def hold_barrier(self, key: int, until: float) -> None:
        """Master only: fire nothing of barrier ``key`` before ``until``, so that requests
        on their way are chosen by their bids rather than by who arrives first
        (:meth:`~actorswarm.core.barrier.BarrierMaster.hold`). Elsewhere it does nothing."""
        if self.is_master:
            self._bmaster.hold(key, until)

    def role_holders(self, role: str) -> tuple[int, ...]:
        """Master only: who holds ``role`` according to the master's table."""
        return self._rmaster.holders(role)

    def _dispatch(self, packet: Packet, now: float) -> None:
        body = packet.body
        if self._heard is not None and packet.sender != wire.GROUND_STATION:
            self._heard.heard(packet.sender, now)
        if type(body) is Heartbeat:
            self._on_heartbeat(packet.sender, packet.incarnation, body, now, packet.seq)
            return
        if packet.sender != wire.GROUND_STATION and self.members.is_newer(
            packet.sender, packet.incarnation
        ):
            # A rebooted peer's first packet may come before its first heartbeat: the old
            # incarnation leaves first, so nothing granted to the new one is taken back.
            left: list[MemberJoined | MemberLeft] = []
            self.members.note_incarnation(packet.sender, packet.incarnation, left)
            self._membership_changed(left, now)
        _BODY_HANDLERS[type(body)](self, packet, now)

    # --- one handler per body type (the table _BODY_HANDLERS below the class) -----------

    def _packet_data(self, packet: Packet, now: float) -> None:
        assert isinstance(packet.body, Data)
        self._on_data(packet.sender, packet.incarnation, packet.body, now)

    def _packet_ack(self, packet: Packet, now: float) -> None:
        body = packet.body
        assert isinstance(body, Ack)
        if body.dst != self.platform or body.dst_incarnation != self.incarnation:
            self.counters["drop:not_for_me"] += 1
            return
        self.reliable.on_ack(packet.sender, body, now)

    def _packet_release(self, packet: Packet, now: float) -> None:
        assert isinstance(packet.body, Release)
        self._on_release(packet.sender, packet.body, now)

    def _packet_roster_request(self, packet: Packet, now: float) -> None:
        body = packet.body
        assert isinstance(body, RosterRequest)
        if not (self._star and self.is_master and body.epoch == self.epoch):
            self.counters["drop:roster"] += 1
            return
        self._roster_requests.add(packet.sender)

    def _packet_roster_chunk(self, packet: Packet, now: float) -> None:
        assert isinstance(packet.body, RosterChunk)
        self._on_roster_chunk(packet.sender, packet.body, now)

    def _packet_bulletin(self, packet: Packet, now: float) -> None:
        assert isinstance(packet.body, Bulletin)
        self._on_bulletin(packet.sender, packet.incarnation, packet.body, now)

    def _packet_bulletin_ack(self, packet: Packet, now: float) -> None:
        body = packet.body
        assert isinstance(body, BulletinAck)
        if body.dst != self.platform or body.dst_incarnation != self.incarnation:
            self.counters["drop:not_for_me"] += 1
            return
        self._board.on_ack(packet.sender, body)

    def _packet_release_ack(self, packet: Packet, now: float) -> None:
        body = packet.body
        assert isinstance(body, ReleaseAck)
        if body.dst != self.platform or not self.is_master or body.epoch != self.epoch:
            self.counters["drop:stale_epoch"] += 1
            return
        self._bmaster.on_ack(packet.sender, body.key, body.generation)

    def _on_bulletin(self, sender: int, incarnation: int, bulletin: Bulletin, now: float) -> None:
        delivered, ack = self._inbox.on_bulletin(sender, incarnation, bulletin)
        if ack is None:
            self.counters["drop:bulletin"] += 1
            return
        self._emit(sender, ack, NORMAL)
        self._deliver_bulletins(sender, incarnation, delivered)

    def _on_data(self, sender: int, incarnation: int, data: Data, now: float) -> None:
        if data.dst != self.platform:
            self.counters["drop:not_for_me"] += 1
            return
        delivered, ack = self.reliable.on_data(sender, incarnation, data)
        if ack is not None:
            self._emit(sender, ack, URGENT if data.channel == URGENT else NORMAL)
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
        if isinstance(payload, AppMessage):
            self._out.events.append(
                AppReceived(sender=sender, topic=payload.topic, body=payload.body, stream=stream)
            )
        elif isinstance(payload, Sync):
            self._on_sync(sender, payload, now, -1 if stream is None else stream[0])
        elif isinstance(payload, MASTER_BOUND):
            if not self.is_master or epoch != self.epoch:
                self.counters["drop:stale_epoch"] += 1
                return
            if isinstance(payload, Report) and payload.epoch != self.epoch:
                self.counters["drop:stale_epoch"] += 1
                return
            self._master_handle(sender, payload, now)
        elif sender != self.master or epoch != self.epoch:
            self.counters["drop:stale_epoch"] += 1
        else:
            self._member_handle(payload, now)

    def _on_release(self, sender: int, rel: Release, now: float) -> None:
        if sender != self.master or rel.epoch != self.epoch or self.is_master:
            self.counters["drop:stale_epoch"] += 1
            return
        event, ack = self.barriers.on_release(rel)
        if event is not None:
            self._out.events.append(event)
        if ack:
            self._emit(
                sender,
                ReleaseAck(dst=sender, epoch=rel.epoch, key=rel.key, generation=rel.generation),
                NORMAL,
            )

    def _master_handle(self, sender: int, payload: Payload, now: float) -> None:
        bm, rm = self._bmaster, self._rmaster
        if isinstance(payload, BarrierRequest):
            bm.request(sender, payload, now, self.epoch)
        elif isinstance(payload, RoleClaim):
            rm.claim(sender, payload)
        elif isinstance(payload, RoleRelease):
            rm.release(sender, payload.role)
        elif isinstance(payload, Report):
            if sender != self.platform and sender not in self.members:
                bm.topology_changed(now)  # a platform from beyond the view: more may follow
            # Releases first: they decide whether a waiting request is to be completed.
            for record in payload.released:
                bm.record_released(sender, record)
            for key, generation in payload.generations.items():
                bm.known_generation(key, generation, now, self.epoch)
            for req in payload.pending:
                bm.request(sender, req, now, self.epoch)
            bm.reported(now, self.epoch)
            rm.report(sender, payload.held, payload.claims)
            self._reported.add(sender)
            if sender in self._handshake_waiting:
                self._handshake_waiting.discard(sender)
                if not self._handshake_waiting and self._handshake_deadline is not None:
                    self._finish_handshake(now)
        self._flush_master(now)

    def _flush_master(self, now: float) -> None:
        """Send what the barrier and role tables decided; apply the parts meant for me.

        The tables keep lists of their own rather than writing into the collector: what they
        decided is routed here (to this platform or over a stream), and their firings are
        reported here, after the view changes of the same step that set them off."""
        bm, rm = self._bmaster, self._rmaster
        self._out.events.extend(bm.events)
        bm.events.clear()
        for platform, notice in bm.notices:
            self._to_member(platform, notice, now)
        bm.notices.clear()
        for platform, reply in rm.replies:
            self._to_member(platform, reply, now)
        rm.replies.clear()
        for rel in bm.broadcasts:
            if any(e.platform == self.platform for e in rel.entries):
                event, _ = self.barriers.on_release(rel)
                if event is not None:
                    self._out.events.append(event)
                bm.on_ack(self.platform, rel.key, rel.generation)
                if all(e.platform == self.platform for e in rel.entries):
                    continue
            self._emit(addressee(rel, self.platform), rel, NORMAL)
        bm.broadcasts.clear()
        for key, generation, unacked in bm.failed:
            self._out.events.append(
                DeliveryFailed(
                    dst=None,
                    kind="Release",
                    reason=f"barrier {key}/{generation}: no acknowledgement from {sorted(unacked)}",
                )
            )
        bm.failed.clear()

    def _member_handle(self, payload: Payload, now: float) -> None:
        if isinstance(payload, BarrierStale):
            notice = self.barriers.on_stale(payload)
            if notice is not None:
                self._out.events.append(notice)
        elif isinstance(payload, RoleGrant | RoleDeny | RoleRevoke):
            event = self.roles.on_reply(payload)
            if event is not None:
                self._out.events.append(event)


__all__ = ["Node", "Outgoing", "Ready"]


#: What a received packet's body is handed to (heartbeats are taken first, in
#: :meth:`Node._dispatch`); the wire decoder produces no other body type.
_BODY_HANDLERS: Final[dict[type[Any], Callable[[Node, Packet, float], None]]] = {
    Data: Node._packet_data,
    Ack: Node._packet_ack,
    Release: Node._packet_release,
    RosterRequest: Node._packet_roster_request,
    RosterChunk: Node._packet_roster_chunk,
    Bulletin: Node._packet_bulletin,
    BulletinAck: Node._packet_bulletin_ack,
    ReleaseAck: Node._packet_release_ack,
}
