"""One platform's collective core: the sans-IO object every host drives.

Theory of operation
-------------------
A host (the simulator, the daemon) owns a :class:`Node` and does four things with it:

* hands it every packet that arrives — :meth:`Node.receive` for untrusted bytes, or
  :meth:`Node.receive_packet` for a packet already decoded once for many receivers;
* calls :meth:`Node.tick` no later than :meth:`Node.next_deadline`;
* sends what :meth:`Node.drain_outgoing` returns (``dst`` None is a broadcast);
* reads what :meth:`Node.drain_events` returns.

The application (task engine, tests) asks for coordination with :meth:`request_barrier`,
:meth:`claim_role`, :meth:`release_role` and :meth:`send_app`. Every call takes ``now``; the
node reads no clock, opens no socket, starts no thread and draws randomness only from the
seeded ``rng`` it was given (the phase of its heartbeats).

Inside, the node composes membership (:mod:`.membership`), election (:mod:`.election`),
reliable streams (:mod:`.reliable`), barriers (:mod:`.barrier`) and roles (:mod:`.roles`).
Master-bound messages are sent to the current master — or handled in place when this platform
is the master — and wait, in order, while there is none. Packets that fail any check are
dropped and counted in :attr:`Node.counters`, never raised: untrusted bytes cannot crash a
platform nor change its state.
"""

from __future__ import annotations

import random
from collections import Counter
from dataclasses import dataclass
from typing import Any

from actorswarm.core import wire
from actorswarm.core.barrier import BarrierMaster, BarrierMember, Scatter
from actorswarm.core.config import CoreConfig
from actorswarm.core.election import OnHeartbeat, on_heartbeat, should_claim
from actorswarm.core.events import (
    AppReceived,
    BecameMaster,
    CoreEvent,
    DeliveryFailed,
    HandshakeComplete,
    MasterChanged,
    MemberJoined,
    MemberLeft,
    SteppedDown,
)
from actorswarm.core.membership import Membership
from actorswarm.core.reliable import Reliable
from actorswarm.core.roles import RoleMaster, RoleMember
from actorswarm.core.wire import (
    NORMAL,
    URGENT,
    Ack,
    AppMessage,
    BarrierRequest,
    BarrierStale,
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
    Sync,
    WireError,
)

_MASTER_BOUND = (BarrierRequest, RoleClaim, RoleRelease, Report)
_MASTER_SENT = (BarrierStale, RoleGrant, RoleDeny, RoleRevoke)
_KEEP_ERRORS = 20


@dataclass(frozen=True, slots=True)
class Outgoing:
    """A packet to transmit: ``dst`` None is a broadcast; ``kind`` names the body type."""

    dst: int | None
    data: bytes
    kind: str
    channel: int


class Node:
    """The collective core of platform ``platform`` (1..65535) in its ``incarnation``."""

    def __init__(
        self,
        platform: int,
        *,
        swarm: str = "swarm",
        incarnation: int = 0,
        config: CoreConfig | None = None,
        now: float = 0.0,
        rng: random.Random | None = None,
    ) -> None:
        if not 1 <= platform <= wire.MAX_PLATFORM:
            raise ValueError(f"platform ID must be 1..{wire.MAX_PLATFORM}, got {platform}")
        if incarnation < 0:
            raise ValueError(f"incarnation must be >= 0, got {incarnation}")
        self.platform = platform
        self.swarm = swarm
        self.incarnation = incarnation
        self.config = config or CoreConfig()
        self._rng = rng if rng is not None else random.Random(platform)
        self._started = now
        self._seq = 0
        self.members = Membership(platform, self.config)
        self.reliable = Reliable(self.config)
        self.barriers = BarrierMember(platform)
        self.roles = RoleMember()
        self._bmaster = self._new_barrier_master()
        self._rmaster = RoleMaster()
        # Election state: ``_epoch_master`` claimed ``epoch``; ``master`` is whom we follow
        # now (None while we have lost it).
        self.epoch = 0
        self.master: int | None = None
        self._epoch_master: int | None = None
        self.is_master = False
        self._max_epoch = 0
        self._best_claim: tuple[int, int, float] | None = None  # (epoch, sender, heard at)
        self._handshake_waiting: set[int] = set()
        self._handshake_deadline: float | None = None
        self._sync_at: float | None = None
        self.handshake_complete = False
        self._lowest_peer: int | None = None
        self._awake = False
        # When the master was last heard: a master followed before it joined the view (or
        # that left it and came back) has no leave detector of its own yet.
        self._master_heard = now
        self._next_heartbeat = now + self._rng.uniform(0.0, self.config.heartbeat_interval)
        self._outgoing: list[Outgoing] = []
        self._changes: list[MemberJoined | MemberLeft] = []
        self._events: list[CoreEvent] = []
        self.counters: Counter[str] = Counter()
        #: Unexpected internal errors caught at the packet boundary (kept for diagnosis;
        #: tests require it to stay empty).
        self.errors: list[str] = []
        #: Hook for the task engine: resolves a barrier need of NEED_ALL (default: every
        #: live platform in the master's view).
        self.resolve_all = self._all_live
        #: Hook for the task engine: per-participant data a release scatters (default: none,
        #: each participant learns only its index). Used whenever this platform is master.
        self.scatter: Scatter | None = None

    # --- read-only views ------------------------------------------------------------------

    @property
    def view(self) -> tuple[int, ...]:
        """Live platforms in this platform's view, itself included, ascending."""
        return tuple(sorted((*self.members.peers, self.platform)))

    def _all_live(self, key: int, part: int) -> int:
        return len(self.members) + 1

    def _new_barrier_master(self) -> BarrierMaster:
        # Late-bound, so the engine may replace ``resolve_all`` after construction.
        master = BarrierMaster(self.config, resolve_all=lambda k, p: self.resolve_all(k, p))  # noqa: PLW0108
        master.scatter = lambda k, g, chosen: self.scatter(k, g, chosen) if self.scatter else {}
        master.first_retry = lambda: self.reliable.timeout(None)
        return master

    # --- host interface -------------------------------------------------------------------

    @property
    def has_output(self) -> bool:
        """Whether packets or events wait to be drained.

        A host may skip :meth:`next_deadline` after a ``receive`` that left no output: a
        packet that makes the node send or report nothing never brings a deadline forward
        (at 1000 platforms this saves a call per heartbeat heard).
        """
        return bool(self._outgoing or self._events or self.reliable.outbox)

    def drain_outgoing(self) -> list[Outgoing]:
        """Packets to send, ground-station (urgent) channel first, then in creation order."""
        self._flush_reliable()
        out = self._outgoing
        self._outgoing = []
        if any(o.channel == URGENT for o in out):
            out.sort(key=lambda o: o.channel)
        return out

    def drain_events(self) -> list[CoreEvent]:
        events = self._events
        self._events = []
        return events

    def next_deadline(self) -> float | None:
        """The latest time by which :meth:`tick` must be called next."""
        best = self._next_heartbeat
        for t in (
            self.members.next_deadline(),
            self.reliable.next_deadline(),
            self._bmaster.next_deadline() if self.is_master else None,
            self._handshake_deadline,
            self._sync_at,
        ):
            if t is not None and t < best:
                best = t
        if not self._awake:
            best = min(best, self._started + self.config.startup_wait)
        if self.master is not None and not self.is_master and self.master not in self.members:
            best = min(best, self._master_heard + self.config.t_leave)
        return best

    def _master_unheard_since(self, now: float) -> bool:
        """The followed master is outside the view and silent for ``t_leave``."""
        return (
            self.master is not None
            and not self.is_master
            and self.master not in self.members
            and now - self._master_heard >= self.config.t_leave
        )

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
        the operator's commands) is processed before swarm traffic (DESIGN.md §3.3)."""
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
            if len(self.errors) < _KEEP_ERRORS:
                self.errors.append(f"{type(exc).__name__}: {exc} (packet {packet!r})")

    def tick(self, now: float) -> None:
        """Advance timers to ``now``: leaves, elections, heartbeats, retransmissions."""
        if not self._awake and now >= self._started + self.config.startup_wait:
            self._awake = True  # listened long enough to know whether a master exists
        joined_left: list[MemberJoined | MemberLeft] = []
        self.members.expire(now, joined_left)
        self._membership_changed(joined_left, now)
        if self._master_unheard_since(now):
            self._lose_master(now)
            self._maybe_claim(now)
        self._maybe_claim(now)
        if self.is_master:
            if self._sync_at is not None and now >= self._sync_at:
                self._sync_at = None
                for peer in sorted(self._handshake_waiting):
                    self.reliable.send(peer, Sync(epoch=self.epoch), now, self.epoch)
            if self._handshake_deadline is not None and now >= self._handshake_deadline:
                self._finish_handshake(now)
            self._bmaster.tick(now, self.epoch)
            self._flush_master(now)
        self.reliable.tick(now)
        self._report_failures()
        if now >= self._next_heartbeat:
            self._send_heartbeat()
            interval = self.config.heartbeat_interval
            self._next_heartbeat += interval
            if self._next_heartbeat <= now:  # the host fell behind: do not burst
                self._next_heartbeat = now + interval

    # --- application interface ------------------------------------------------------------

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
    ) -> int:
        """Ask to pass barrier ``key``; returns the generation asked for.

        ``need`` is the number of participants (or :data:`~actorswarm.core.wire.NEED_ALL`),
        or a map part -> number for a barrier of several parts. The answer comes as a
        :class:`~actorswarm.core.events.BarrierReleased` (or ``BarrierStaleNotice``) event.
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
                self._events.append(AppReceived(sender=self.platform, topic=topic, body=body))
            else:
                self.reliable.send_to_master(msg, now, self.epoch)
        elif dst == self.platform:
            self._events.append(AppReceived(sender=self.platform, topic=topic, body=body))
        else:
            self.reliable.send(dst, msg, now, self.epoch, channel=channel)

    def role_holders(self, role: str) -> tuple[int, ...]:
        """Master only: who holds ``role`` according to the master's table."""
        return self._rmaster.holders(role)

    # --- packet dispatch ------------------------------------------------------------------

    def _dispatch(self, packet: Packet, now: float) -> None:
        body = packet.body
        if isinstance(body, Heartbeat):
            self._on_heartbeat(packet.sender, packet.incarnation, body, now, packet.seq)
        elif isinstance(body, Data):
            self._on_data(packet.sender, packet.incarnation, body, now)
        elif isinstance(body, Ack):
            if body.dst != self.platform or body.dst_incarnation != self.incarnation:
                self.counters["drop:not_for_me"] += 1
                return
            self.reliable.on_ack(packet.sender, body, now)
        elif isinstance(body, Release):
            self._on_release(packet.sender, body, now)
        else:  # ReleaseAck
            if body.dst != self.platform or not self.is_master or body.epoch != self.epoch:
                self.counters["drop:stale_epoch"] += 1
                return
            self._bmaster.on_ack(packet.sender, body.key, body.generation)

    def _on_heartbeat(
        self, sender: int, incarnation: int, hb: Heartbeat, now: float, seq: int
    ) -> None:
        if sender == wire.GROUND_STATION:
            self.counters["drop:not_for_me"] += 1
            return
        changes = self._changes  # reused: this runs for every heartbeat heard
        self.members.heartbeat(sender, incarnation, now, changes, seq)
        if changes:
            self._changes = []
            self._membership_changed(changes, now)
        self._max_epoch = max(self._max_epoch, hb.epoch)
        if sender == self.master:
            self._master_heard = now
        if not (hb.is_master or self.is_master or sender == self._epoch_master):
            return  # the common case at scale: an ordinary member's heartbeat
        action = on_heartbeat(
            self_id=self.platform,
            is_master=self.is_master,
            epoch=self.epoch,
            master=self._epoch_master,
            master_alive=self.master is not None,
            sender=sender,
            sender_is_master=hb.is_master,
            sender_epoch=hb.epoch,
        )
        if action is OnHeartbeat.IGNORE:
            better = self._best_claim is None or hb.epoch > self._best_claim[0]
            if hb.is_master and hb.epoch > self.epoch and better:
                self._best_claim = (hb.epoch, sender, now)
            return
        if self._apply(action, sender, hb.epoch, now):
            return
        if action is OnHeartbeat.DEMOTED:  # my master gave up; follow whom it follows, if any
            self._lose_master(now)
            if hb.master not in (0, self.platform, sender):
                self._epoch_master = hb.master

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
            self._events.append(
                AppReceived(sender=sender, topic=payload.topic, body=payload.body, stream=stream)
            )
        elif isinstance(payload, Sync):
            self._on_sync(sender, payload, now)
        elif isinstance(payload, _MASTER_BOUND):
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

    def _on_sync(self, sender: int, sync: Sync, now: float) -> None:
        self._max_epoch = max(self._max_epoch, sync.epoch)
        if sender == self.master and sync.epoch == self.epoch:
            self._report(now)
            return
        action = on_heartbeat(
            self_id=self.platform,
            is_master=self.is_master,
            epoch=self.epoch,
            master=self._epoch_master,
            master_alive=self.master is not None,
            sender=sender,
            sender_is_master=True,
            sender_epoch=sync.epoch,
        )
        if not self._apply(action, sender, sync.epoch, now):
            self.counters["drop:stale_epoch"] += 1

    def _apply(self, action: OnHeartbeat, sender: int, epoch: int, now: float) -> bool:
        """Carry out an election decision about ``sender``'s claim of ``epoch``; False when
        the decision is left to the caller (IGNORE, DEMOTED)."""
        if action is OnHeartbeat.FOLLOW:
            self._follow(sender, epoch, now)
        elif action is OnHeartbeat.STEP_DOWN:
            self._step_down(sender, now)
            if epoch > self.epoch:
                self._follow(sender, epoch, now)
        elif action is OnHeartbeat.RECLAIM:
            self._claim(now)
        else:
            return False
        return True

    def _on_release(self, sender: int, rel: Release, now: float) -> None:
        if sender != self.master or rel.epoch != self.epoch or self.is_master:
            self.counters["drop:stale_epoch"] += 1
            return
        event, ack = self.barriers.on_release(rel)
        if event is not None:
            self._events.append(event)
        if ack:
            self._emit(
                sender,
                ReleaseAck(dst=sender, epoch=rel.epoch, key=rel.key, generation=rel.generation),
                NORMAL,
            )

    # --- membership and election ------------------------------------------------------------

    def _membership_changed(self, changes: list[MemberJoined | MemberLeft], now: float) -> None:
        if not changes:
            return
        for change in changes:
            self._events.append(change)
            if isinstance(change, MemberLeft):
                self.reliable.drop_destination(change.platform, now)
                if change.reason == "restarted":
                    self.reliable.forget_sender(change.platform)
                if self.is_master:
                    self._handshake_waiting.discard(change.platform)
                    self._bmaster.member_left(change.platform, now, self.epoch)
                    self._rmaster.member_left(change.platform)
                if change.platform == self.master:
                    self._lose_master(now)
            elif self.is_master:
                # A newcomer (or a member back from a false alarm, or from the other side of
                # a healed partition) must follow and report; until it has, the master decides
                # nothing, since the report may show a firing to complete.
                self.reliable.send(change.platform, Sync(epoch=self.epoch), now, self.epoch)
                self._handshake_waiting.add(change.platform)
                self._bmaster.topology_changed(now)
                if self._handshake_deadline is None:
                    self._handshake_deadline = now + self.config.handshake_timeout
                self._bmaster.ready = False
                self._rmaster.ready = False
        self._update_lowest_peer(changes)
        self._report_failures()
        if self.is_master:
            if self._handshake_deadline is not None and not self._handshake_waiting:
                self._finish_handshake(now)
            self._flush_master(now)
        self._maybe_claim(now)

    def _update_lowest_peer(self, changes: list[MemberJoined | MemberLeft]) -> None:
        """Keep the lowest ID of the view in O(1) per join; only losing the lowest one costs
        a scan (at boot a platform sees N joins: a scan per join would be O(N²))."""
        lowest = self._lowest_peer
        for change in changes:
            if isinstance(change, MemberJoined):
                if lowest is None or change.platform < lowest:
                    lowest = change.platform
            elif change.platform == lowest:
                lowest = None if not self.members.peers else -1
        if lowest == -1:
            lowest = min(self.members.peers)
        self._lowest_peer = lowest

    def _report_failures(self) -> None:
        """Every message the reliable layer gave up on becomes a DeliveryFailed event."""
        for failure in self.reliable.failures:
            reason = (
                "the destination left the swarm"
                if failure.reason == "left"
                else f"not acknowledged within {self.config.delivery_deadline} s"
            )
            self._events.append(
                DeliveryFailed(dst=failure.dst, kind=type(failure.payload).__name__, reason=reason)
            )
        self.reliable.failures.clear()

    def _maybe_claim(self, now: float) -> None:
        if should_claim(
            self_id=self.platform,
            lowest_peer=self._lowest_peer,
            is_master=self.is_master,
            master=self.master,
            master_alive=self.master is not None,
            takeover_on_join=self.config.takeover_on_join,
            listened=now - self._started,
            startup_wait=self.config.startup_wait,
        ):
            self._claim(now)

    def _claim(self, now: float) -> None:
        """Become master in a new epoch above every epoch seen; start the handshake."""
        self._max_epoch += 1
        self._set_epoch(self._max_epoch, self.platform)
        self.master = self.platform
        if not self.is_master:
            self.is_master = True
            self._bmaster = self._new_barrier_master()
            self._rmaster = RoleMaster()
        else:  # a new epoch while master: everyone reports again, nothing fires meanwhile
            self._bmaster.ready = False
            self._rmaster.ready = False
        self.handshake_complete = False
        self._bmaster.topology_changed(now)
        self._events.append(BecameMaster(epoch=self.epoch))
        self._events.append(MasterChanged(master=self.platform, epoch=self.epoch))
        self.reliable.retarget(None, now)
        self._handshake_waiting = set(self.members.peers)
        self._handshake_deadline = now + self.config.handshake_timeout
        # Members follow the claim heartbeat and report on their own; a Sync goes only to
        # those who have not reported after a round trip's worth of retry delay.
        self._sync_at = now + 2 * self.config.retry_base
        self._send_heartbeat()
        # The master's own state counts like any member's report.
        self._master_handle(self.platform, self._own_report(now), now)
        for payload in self.reliable.take_unrouted():
            self._master_handle(self.platform, payload, now)
        if not self._handshake_waiting:
            self._finish_handshake(now)

    def _finish_handshake(self, now: float) -> None:
        self._handshake_deadline = None
        self._sync_at = None
        if self._handshake_waiting:
            self.counters["handshake_incomplete"] += 1
        self._handshake_waiting.clear()
        if not self.handshake_complete:
            self.handshake_complete = True
            self._events.append(HandshakeComplete(epoch=self.epoch, members=len(self.members)))
        self._bmaster.become_ready(now, self.epoch)
        self._rmaster.become_ready()
        self._flush_master(now)

    def _step_down(self, to: int, now: float) -> None:
        self.is_master = False
        self.handshake_complete = False
        self._handshake_waiting.clear()
        self._handshake_deadline = None
        self._sync_at = None
        self._events.append(SteppedDown(epoch=self.epoch, to=to))
        self.master = None
        self._epoch_master = to
        self._events.append(MasterChanged(master=None, epoch=self.epoch))

    def _follow(self, master: int, epoch: int, now: float) -> None:
        if self.is_master:
            self._step_down(master, now)
        self._set_epoch(epoch, master)
        self.master = master
        self._master_heard = now
        self._best_claim = None
        self._events.append(MasterChanged(master=master, epoch=epoch))
        self.reliable.retarget(master, now)
        # Always report: requests and claims made while no master was followed were not sent
        # (the report states them), and a resumed master may have dropped us meanwhile.
        self._report(now)

    def _lose_master(self, now: float) -> None:
        if self.master is None:
            return
        self.master = None
        self._events.append(MasterChanged(master=None, epoch=self.epoch))
        self.reliable.retarget(None, now)
        claim = self._best_claim
        if (
            claim is not None
            and claim[0] > self.epoch
            and now - claim[2] <= self.config.t_leave
            and claim[1] in self.members
        ):
            # Someone already claimed while we still trusted the old master: follow at once.
            self._follow(claim[1], claim[0], now)

    def _set_epoch(self, epoch: int, master: int) -> None:
        if epoch < self.epoch:
            raise AssertionError(f"epoch would go back from {self.epoch} to {epoch}")
        self.epoch = epoch
        self._epoch_master = master
        self.barriers.adopt_epoch(epoch)
        self._max_epoch = max(self._max_epoch, epoch)

    # --- master side ------------------------------------------------------------------------

    def _own_report(self, now: float) -> Report:
        return Report(
            epoch=self.epoch,
            generations=dict(self.barriers.known),
            pending=self.barriers.restated(now),
            released=self.barriers.records(),
            held=list(self.roles.held.values()),
            claims=list(self.roles.claims.values()),
        )

    def _report(self, now: float) -> None:
        if self.master is None or self.master == self.platform:
            return
        self.reliable.send(self.master, self._own_report(now), now, self.epoch)

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
            if sender in self._handshake_waiting:
                self._handshake_waiting.discard(sender)
                if not self._handshake_waiting and self._handshake_deadline is not None:
                    self._finish_handshake(now)
        self._flush_master(now)

    def _flush_master(self, now: float) -> None:
        """Send what the barrier and role tables decided; apply the parts meant for me."""
        bm, rm = self._bmaster, self._rmaster
        self._events.extend(bm.events)
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
                    self._events.append(event)
                bm.on_ack(self.platform, rel.key, rel.generation)
                if all(e.platform == self.platform for e in rel.entries):
                    continue
            self._emit(None, rel, NORMAL)
        bm.broadcasts.clear()
        for key, generation, unacked in bm.failed:
            self._events.append(
                DeliveryFailed(
                    dst=None,
                    kind="Release",
                    reason=f"barrier {key}/{generation}: no acknowledgement from {sorted(unacked)}",
                )
            )
        bm.failed.clear()

    def _to_master(self, payload: Payload, now: float) -> None:
        """Barrier and role traffic for the master. Without a master nothing is queued: the
        report sent on following the next master states every pending request and claim."""
        if self.is_master:
            self._master_handle(self.platform, payload, now)
        elif self.master is not None:
            self.reliable.send_to_master(payload, now, self.epoch)

    def _to_member(self, platform: int, payload: Payload, now: float) -> None:
        if platform == self.platform:
            self._member_handle(payload, now)
        else:
            self.reliable.send(platform, payload, now, self.epoch)

    def _member_handle(self, payload: Payload, now: float) -> None:
        if isinstance(payload, BarrierStale):
            notice = self.barriers.on_stale(payload)
            if notice is not None:
                self._events.append(notice)
        elif isinstance(payload, RoleGrant | RoleDeny | RoleRevoke):
            event = self.roles.on_reply(payload)
            if event is not None:
                self._events.append(event)

    # --- output -----------------------------------------------------------------------------

    def _send_heartbeat(self) -> None:
        hb = Heartbeat(
            is_master=self.is_master,
            epoch=self.epoch,
            master=self.master or 0,
        )
        self._emit(None, hb, NORMAL)

    def _emit(self, dst: int | None, body: wire.Body, channel: int) -> None:
        self._flush_reliable()
        self._seq += 1
        data = wire.encode(
            swarm=self.swarm,
            sender=self.platform,
            incarnation=self.incarnation,
            seq=self._seq,
            body=body,
        )
        self._outgoing.append(Outgoing(dst, data, type(body).__name__, channel))

    def _flush_reliable(self) -> None:
        box = self.reliable.outbox
        if not box:
            return
        self.reliable.outbox = []
        for dst, body in box:
            self._seq += 1
            data = wire.encode(
                swarm=self.swarm,
                sender=self.platform,
                incarnation=self.incarnation,
                seq=self._seq,
                body=body,
            )
            channel = body.channel
            self._outgoing.append(Outgoing(dst, data, type(body).__name__, channel))


__all__ = ["Node", "Outgoing"]
