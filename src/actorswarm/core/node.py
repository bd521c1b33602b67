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

import math
import random
from collections import Counter
from dataclasses import dataclass
from typing import Any

from actorswarm.core import wire
from actorswarm.core.barrier import BarrierMaster, BarrierMember, Scatter
from actorswarm.core.bulletin import BulletinBoard, BulletinInbox
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
from actorswarm.core.roster import RosterLog, RosterView
from actorswarm.core.wire import (
    BULLETIN_STREAM,
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

_MASTER_BOUND = (BarrierRequest, RoleClaim, RoleRelease, Report)
_MASTER_SENT = (BarrierStale, RoleGrant, RoleDeny, RoleRevoke)
_KEEP_ERRORS = 20
#: A master that has more members asking for the whole roster than this at one heartbeat
#: broadcasts it once instead of sending it to each.
_ROSTER_BROADCAST_FROM = 4
#: Local health (Lifeguard): at most this many heartbeat intervals of grace for a host that
#: ticks late.
_MAX_HEALTH = 8


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
        # Master to every member as one broadcast (event relays, what the master runs).
        self._board = BulletinBoard(self.config)
        self._claim_bulletin = 0  # the first bulletin of the members of the claim
        self._inbox = BulletinInbox(platform)
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
        interval = self.config.heartbeat_interval
        if self.config.membership == "star":
            # Lower IDs speak first at boot (up to one interval later for the highest ID), so
            # a booting swarm hears its lowest IDs before the others would broadcast, and
            # they keep quiet. The phase is drawn afresh after this first heartbeat.
            self._next_heartbeat = now + interval * (
                math.log2(platform) / 16 + self._rng.uniform(0.0, 0.05)
            )
            self._rephase = True
        else:
            self._next_heartbeat = now + self._rng.uniform(0.0, interval)
            self._rephase = False
        # Star topology (DESIGN.md §3.1): the roster as the master keeps it and as members
        # copy it, the member heartbeat interval the master asks for, and the succession
        # entries presumed alive after the master was lost (platform -> presumed until).
        self._star = self.config.membership == "star"
        self.roster = RosterView()
        self._roster_log = RosterLog(self.config.succession)
        self._roster_requests: set[int] = set()
        self._roster_asked = -1e9
        self._roster_broadcast_at = -1e9
        self._cadence = self.config.heartbeat_interval
        self._presumed: dict[int, float] = {}
        self._heard_lower: dict[int, float] = {}
        #: Since when this platform has elected as in broadcast mode (no master, no
        #: presumed successor): only then may a platform outside the succession list claim.
        self._listening_since = now
        self._hb_count = 0
        # Suspicion: when each suspect is probed next, when each prober was last answered.
        self._probe_due: dict[int, float] = {}
        self._answered: dict[int, float] = {}
        # Master: who reported in this epoch, and who did and was then declared gone.
        self._reported: set[int] = set()
        self._rejoining: set[int] = set()
        # Local health: how late the host ticks, as a grace on every leave decision.
        self._due = now
        self._health = 0
        self._health_decay_at = now
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
        """Live platforms in this platform's view, itself included, ascending.

        A star member that follows a master sees the swarm through its master: the master's
        roster (as far as this member has it), the master and itself.
        """
        if self._following_star():
            return tuple(sorted({*self.roster.members, self.master or 0, self.platform} - {0}))
        return tuple(sorted((*self.members.peers, self.platform)))

    def _following_star(self) -> bool:
        """A star member that follows a live remote master (heartbeats to it only)."""
        return self._star and self.master is not None and not self.is_master

    @property
    def grace(self) -> float:
        """Extra patience of every leave decision while this host ticks late."""
        return self._health * self.config.heartbeat_interval

    def _all_live(self, key: int, part: int) -> int:
        return len(self.members) + 1

    def _new_barrier_master(self) -> BarrierMaster:
        # Late-bound, so the engine may replace ``resolve_all`` after construction.
        master = BarrierMaster(
            self.config,
            resolve_all=lambda k, p: self.resolve_all(k, p),  # noqa: PLW0108
            platform=self.platform,
        )
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
            best = min(best, self._master_heard + self.members.silence())
        self._due = best
        return best

    def _master_unheard_since(self, now: float) -> bool:
        """The followed master is outside the view and silent for ``t_leave``."""
        return (
            self.master is not None
            and not self.is_master
            and self.master not in self.members
            and now - self._master_heard >= self.members.silence()
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
        self._check_health(now)
        joined_left: list[MemberJoined | MemberLeft] = []
        suspected: list[int] = []
        self.members.expire(now, joined_left, suspected, self.grace)
        for peer in suspected:
            self.counters["suspected"] += 1
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
            self._flush_bulletins()
        self.reliable.tick(now)
        self._report_failures()
        if now >= self._next_heartbeat:
            self._send_heartbeat(now)
            interval = self._cadence if self._following_star() else self.config.heartbeat_interval
            if self._rephase:  # after the boot heartbeat: a phase of its own, not its rank's
                self._rephase = False
                interval *= self._rng.uniform(0.5, 1.5)
            self._next_heartbeat += interval
            if self._next_heartbeat <= now:  # the host fell behind: do not burst
                self._next_heartbeat = now + interval

    def _check_health(self, now: float) -> None:
        """Local health (Lifeguard): a tick later than asked means this host was not
        listening (a starved CPU, a paused process); each one adds a heartbeat interval of
        grace to every leave decision, and every second of punctual ticks takes one away."""
        late = now - self._due
        if late > self.config.heartbeat_interval / 2:
            if self._health < _MAX_HEALTH:
                self._health += 1
                self.counters["late_tick"] += 1
            self._health_decay_at = now + 1.0
        elif self._health and now >= self._health_decay_at:
            self._health -= 1
            self._health_decay_at = now + 1.0

    def _probe(self, now: float) -> None:
        """Probe the suspects directly (a heartbeat naming them, sent to each): at once on
        suspicion, then every ``probe_interval`` while there are few; many suspects at once
        (a master after a mass failure) are probed by the list in the heartbeats alone."""
        if not self._probe_due:
            return
        suspects = self.members.suspects
        for peer in [p for p in self._probe_due if p not in suspects]:
            del self._probe_due[peer]
        if len(self._probe_due) > wire.MAX_SUSPECTS // 4:
            due = [p for p, t in self._probe_due.items() if t == now]  # fresh suspicions only
            for peer in self._probe_due:
                self._probe_due[peer] = now + self.config.heartbeat_interval
        else:
            due = [p for p, t in self._probe_due.items() if t <= now]
        for peer in due:
            self.counters["probe"] += 1
            self._emit(peer, self._heartbeat(now, suspects=[peer]), NORMAL)
            self._probe_due[peer] = now + self.config.probe_interval

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
        self._flush_bulletins()

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
        elif isinstance(body, RosterRequest):
            if not (self._star and self.is_master and body.epoch == self.epoch):
                self.counters["drop:roster"] += 1
                return
            self._roster_requests.add(packet.sender)
        elif isinstance(body, RosterChunk):
            self._on_roster_chunk(packet.sender, body, now)
        elif isinstance(body, Bulletin):
            self._on_bulletin(packet.sender, packet.incarnation, body, now)
        elif isinstance(body, BulletinAck):
            if body.dst != self.platform or body.dst_incarnation != self.incarnation:
                self.counters["drop:not_for_me"] += 1
                return
            self._board.on_ack(packet.sender, body)
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
        if hb.suspects and self.platform in hb.suspects:
            self._answer_probe(sender, now)
        self._max_epoch = max(self._max_epoch, hb.epoch)
        if sender < self.platform and self._star and self.master is None:
            # Only a lower ID that follows no master either keeps this one quiet: one that
            # follows a master this platform does not (its probe answers reach me) or is a
            # master itself cannot stand in for me in an election.
            if hb.is_master or hb.master:
                self._heard_lower.pop(sender, None)
            else:
                self._heard_lower[sender] = now
        # A star member that follows a master watches that master only: other platforms'
        # heartbeats matter to it for the election alone (a master, or its own master's).
        if not self._following_star() or sender == self.master:
            changes = self._changes  # reused: this runs for every heartbeat heard
            self.members.heartbeat(sender, incarnation, now, changes, seq, hb.count)
            if changes:
                self._changes = []
                self._membership_changed(changes, now, hb)
        if sender == self.master:
            self._master_heard = now
            if hb.is_master and hb.epoch == self.epoch and not self.is_master:
                self._on_master_heartbeat(sender, hb, now)
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
            if action is OnHeartbeat.FOLLOW and self.master == sender:
                self._on_master_heartbeat(sender, hb, now)
            return
        if action is OnHeartbeat.DEMOTED:  # my master gave up; follow whom it follows, if any
            self._lose_master(now)
            if hb.master not in (0, self.platform, sender):
                self._epoch_master = hb.master

    def _on_master_heartbeat(self, sender: int, hb: Heartbeat, now: float) -> None:
        """What a member takes from its master's heartbeat: the cadence it asks for, the
        succession list, and the roster (asking for all of it when behind)."""
        if not self._star:
            return
        self._cadence = hb.cadence if hb.cadence > 0 else self.config.heartbeat_interval
        rejected = self.roster.rejected
        behind = self.roster.on_heartbeat(hb.epoch, hb)
        if self.roster.rejected != rejected:
            self.counters["drop:roster"] += 1
        self._roster_removed(now)
        if behind and now - self._roster_asked >= self.config.retry_cap:
            self._roster_asked = now
            self.counters["roster_request"] += 1
            self._emit(
                sender,
                RosterRequest(
                    epoch=hb.epoch,
                    version=self.roster.version if self.roster.epoch == hb.epoch else 0,
                ),
                NORMAL,
            )

    def _on_roster_chunk(self, sender: int, chunk: RosterChunk, now: float) -> None:
        if not (
            self._star
            and sender == self.master
            and not self.is_master
            and chunk.epoch == self.epoch
        ):
            self.counters["drop:roster"] += 1
            return
        rejected = self.roster.rejected
        self.roster.on_chunk(chunk)
        if self.roster.rejected != rejected:
            self.counters["drop:roster"] += 1
        self._roster_removed(now)

    def _roster_removed(self, now: float) -> None:
        """Platforms that left the master's view left the swarm for this member too: its
        queues to them are dropped and their messages reported failed."""
        if not self.roster.removed:
            return
        for platform in self.roster.removed:
            if platform != self.master:
                self.reliable.drop_destination(platform, now)
        self.roster.removed.clear()
        self._report_failures()

    def _answer_probe(self, prober: int, now: float) -> None:
        """A peer suspects me: answer it directly (at most twice per probe interval)."""
        if now - self._answered.get(prober, -1e9) < self.config.probe_interval / 2:
            return
        if len(self._answered) > 4 * wire.MAX_SUSPECTS:
            horizon = now - self.config.probe_interval
            self._answered = {p: t for p, t in self._answered.items() if t >= horizon}
        self._answered[prober] = now
        self.counters["probe_answered"] += 1
        self._emit(prober, self._heartbeat(now), NORMAL)

    def _on_bulletin(self, sender: int, incarnation: int, bulletin: Bulletin, now: float) -> None:
        delivered, ack = self._inbox.on_bulletin(sender, incarnation, bulletin)
        if ack is None:
            self.counters["drop:bulletin"] += 1
            return
        self._emit(sender, ack, NORMAL)
        self._deliver_bulletins(sender, incarnation, delivered)

    def _deliver_bulletins(self, sender: int, incarnation: int, items: list[Bulletin]) -> None:
        for item in items:
            self._events.append(
                AppReceived(
                    sender=sender,
                    topic=item.message.topic,
                    body=item.message.body,
                    stream=(incarnation, BULLETIN_STREAM, item.seq),
                )
            )

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
        self._sync_bulletins(sender, sync)
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
        self._sync_bulletins(sender, sync)

    def _sync_bulletins(self, sender: int, sync: Sync) -> None:
        """The master's handshake says where this platform's part of its bulletins begins."""
        if sender != self.master or not sync.bulletin:
            return
        self._deliver_bulletins(sender, self._inbox.incarnation, self._inbox.start(sync.bulletin))

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

    def _membership_changed(
        self, changes: list[MemberJoined | MemberLeft], now: float, hb: Heartbeat | None = None
    ) -> None:
        if not changes:
            return
        for change in changes:
            self._events.append(change)
            if isinstance(change, MemberLeft):
                self.reliable.drop_destination(change.platform, now)
                self._probe_due.pop(change.platform, None)
                if change.reason == "restarted":
                    self.reliable.forget_sender(change.platform, change.incarnation)
                if self.is_master:
                    self._handshake_waiting.discard(change.platform)
                    self._bmaster.member_left(change.platform, now, self.epoch)
                    self._rmaster.member_left(change.platform)
                    self._board.member_left(change.platform)
                    self._roster_log.left(change.platform)
                    if change.platform in self._reported and change.reason != "restarted":
                        self._rejoining.add(change.platform)
                    self._reported.discard(change.platform)
                if change.platform == self.master:
                    self._lose_master(now)
            elif self.is_master:
                self._roster_log.joined(change.platform, change.incarnation)
                self._master_joined(change.platform, now, hb)
        self._update_lowest_peer(changes)
        self._report_failures()
        if self.is_master:
            if self._handshake_deadline is not None and not self._handshake_waiting:
                self._finish_handshake(now)
            self._flush_master(now)
        self._maybe_claim(now)

    def _master_joined(self, platform: int, now: float, hb: Heartbeat | None) -> None:
        """A platform joined the master's view. One that already reported in this epoch
        (it followed the claim before its heartbeats made it join) needs nothing more. One
        that reported and was then declared gone (a false alarm) is asked to report again —
        its pending requests were dropped with it — but holds nothing back: everything it
        knows it learnt from this master. Anyone else (a newcomer, the other side of a healed
        partition) must follow and report, and until it has, the master decides nothing,
        since the report may show a firing to complete."""
        if platform in self._reported:
            return
        rejoining = (
            platform in self._rejoining
            and hb is not None
            and hb.epoch == self.epoch
            and hb.master == self.platform
        )
        self._rejoining.discard(platform)
        sync = Sync(epoch=self.epoch, bulletin=self._board.next_seq)
        self.reliable.send(platform, sync, now, self.epoch)
        if rejoining:
            self.counters["rejoined"] += 1
            return
        self._handshake_waiting.add(platform)
        self._bmaster.topology_changed(now)
        if self._handshake_deadline is None:
            self._handshake_deadline = now + self.config.handshake_timeout
        self._bmaster.ready = False
        self._rmaster.ready = False

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
        """Every message the reliable layer (or the bulletin board) gave up on becomes a
        DeliveryFailed event."""
        if self._board.failures:
            self.reliable.failures.extend(self._board.failures)
            self._board.failures.clear()
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
        lowest = self._lowest_peer
        listened = now - self._started
        if self._star and self.master is None and not self.is_master:
            # A star platform also counts the lower IDs it heard but that have not joined its
            # view (they keep quiet only if they hear someone lower still) and the successors
            # it presumes alive. The first live successor takes over at once; anyone else
            # elects as in broadcast mode, having listened for ``startup_wait`` first.
            lower = [p for p in self._presumed if p < self.platform]
            lower += self._lower_heard(now)
            if lower:
                lowest = min(lower) if lowest is None else min(lowest, *lower)
            if self.platform not in self.roster.succession:
                listened = min(listened, now - self._listening_since)
        if should_claim(
            self_id=self.platform,
            lowest_peer=lowest,
            is_master=self.is_master,
            master=self.master,
            master_alive=self.master is not None,
            takeover_on_join=self.config.takeover_on_join,
            listened=listened,
            startup_wait=self.config.startup_wait,
        ):
            self._claim(now)

    def _claim(self, now: float) -> None:
        """Become master in a new epoch above every epoch seen; start the handshake."""
        self._max_epoch += 1
        predecessor = self._epoch_master
        self._set_epoch(self._max_epoch, self.platform)
        self.master = self.platform
        self._inbox.follow(None)
        self._claim_bulletin = self._board.next_seq
        self._presumed.clear()
        self._probe_due.clear()
        self._reported.clear()
        self._rejoining.clear()
        if not self.is_master:
            self.is_master = True
            self._bmaster = self._new_barrier_master()
            self._rmaster = RoleMaster()
            if self._star:
                # The predecessor's roster: those platforms were members a moment ago. They
                # are watched from now on and waited for in the handshake, and those that do
                # not answer leave like any silent member.
                for peer, incarnation in self.roster.members.items():
                    if peer != predecessor:
                        self.members.admit(peer, incarnation, now)
                self._lowest_peer = min(self.members.peers, default=None)
        else:  # a new epoch while master: everyone reports again, nothing fires meanwhile
            self._bmaster.ready = False
            self._rmaster.ready = False
        self._roster_log.reset(self.epoch)
        self._cadence = self._member_cadence()
        self.members.cadence = self._cadence
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
        self._send_heartbeat(now)
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
        self._board.clear("left")
        self._roster_requests.clear()
        self._cadence = self.config.heartbeat_interval
        self.members.cadence = self._cadence
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
        self._presumed.clear()
        if self._star:
            # A star member watches its master only; the rest of the swarm it learns from
            # the master's roster (fetched anew: it is the new master's, or newer).
            for peer in [p for p in self.members.peers if p != master]:
                self.members.forget(peer)
            self._lowest_peer = master if master in self.members else None
            self._probe_due = {p: t for p, t in self._probe_due.items() if p == master}
        self._events.append(MasterChanged(master=master, epoch=epoch))
        self.reliable.retarget(master, now)
        self._inbox.follow(master)
        # Always report: requests and claims made while no master was followed were not sent
        # (the report states them), and a resumed master may have dropped us meanwhile.
        self._report(now)

    def _lose_master(self, now: float) -> None:
        if self.master is None:
            return
        lost = self.master
        self.master = None
        self._listening_since = now
        if self._star:
            # The master's succession list says who takes over: each successor is presumed
            # alive for a while per rank, so the first live one claims without a round of
            # broadcasts, and the others keep quiet meanwhile. The while covers how much
            # later a successor may notice the loss (its last heartbeats from the master
            # arrived, mine were lost); a successor slower than that claims beside the
            # next one, and the lower of the two keeps the role.
            step = 3 * self.config.heartbeat_interval + self.config.probe_window
            for rank, peer in enumerate(p for p in self.roster.succession if p != lost):
                if peer != self.platform:
                    self._presumed[peer] = now + (rank + 1) * step
        self._events.append(MasterChanged(master=None, epoch=self.epoch))
        self.reliable.retarget(None, now)
        self._inbox.follow(None)
        claim = self._best_claim
        if (
            claim is not None
            and claim[0] > self.epoch
            and now - claim[2] <= self.config.t_leave
            and (claim[1] in self.members or self._star)
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
            # A former master also reports the firings it decided (its barrier table is
            # kept until it claims again).
            released=self.barriers.records()
            + ([] if self.is_master else self._bmaster.decided(self.platform)),
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
            self._reported.add(sender)
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

    def _member_cadence(self) -> float:
        """The member heartbeat interval a star master asks for: ``heartbeat_interval``, or
        slower when the members' heartbeats would take more than ``heartbeat_share`` of a
        channel of ``channel_bitrate``."""
        cfg = self.config
        if not self._star or cfg.channel_bitrate is None:
            return cfg.heartbeat_interval
        load = max(len(self.members), 1) * cfg.heartbeat_bits
        return max(cfg.heartbeat_interval, load / (cfg.heartbeat_share * cfg.channel_bitrate))

    def _heartbeat(self, now: float, *, suspects: list[int] | None = None) -> Heartbeat:
        """This platform's heartbeat; a star master's carries what its members need."""
        if suspects is None:
            suspects = self._suspect_list()
        if not (self._star and self.is_master):
            return Heartbeat(
                is_master=self.is_master,
                epoch=self.epoch,
                master=self.master or 0,
                count=self._hb_count,
                suspects=suspects,
            )
        log = self._roster_log
        return Heartbeat(
            is_master=True,
            epoch=self.epoch,
            master=self.platform,
            count=self._hb_count,
            suspects=suspects,
            roster=log.version,
            size=len(self.members),
            changes=list(log.changes),
            succession=log.succession(self.members.peers),
            cadence=0.0 if self._cadence == self.config.heartbeat_interval else self._cadence,
        )

    def _suspect_list(self) -> list[int]:
        """Up to MAX_SUSPECTS suspects, rotating through them when there are more."""
        suspects = self.members.suspects
        if not suspects:
            return []
        ordered = sorted(suspects)
        if len(ordered) <= wire.MAX_SUSPECTS:
            return ordered
        start = (self._hb_count * wire.MAX_SUSPECTS) % len(ordered)
        return (ordered[start:] + ordered[:start])[: wire.MAX_SUSPECTS]

    def _send_heartbeat(self, now: float) -> None:
        """The scheduled heartbeat: to the master alone when following one in a star, else
        broadcast — except that a masterless star platform that hears a lower ID (or presumes
        a lower successor alive) keeps quiet: it could not become master, and at boot this is
        what keeps a thousand platforms from all broadcasting at once."""
        self._hb_count += 1
        if self.is_master and self._star:
            self._cadence = self._member_cadence()
            self.members.cadence = self._cadence
            self._serve_roster_requests(now)
        hb = self._heartbeat(now)
        if self._following_star():
            self._emit(self.master, hb, NORMAL)
        elif self._quiet(now):
            self.counters["heartbeat_quiet"] += 1
        else:
            self._emit(None, hb, NORMAL)

    def _quiet(self, now: float) -> bool:
        if not self._star or self.is_master or self.master is not None:
            return False
        if any(p < self.platform for p in self._presumed):
            return True
        return bool(self._lower_heard(now))

    def _lower_heard(self, now: float) -> list[int]:
        """Lower IDs heard lately without a master (they elect, so I need not be heard).

        A lower ID that is a master does not count: if I do not follow it (its epoch is
        below mine), it must hear me to claim again above my epoch. "Lately" is as long as
        a member stays in a view, so a lost heartbeat or two change nothing."""
        horizon = now - max(self.config.t_join, self.members.silence())
        heard = self._heard_lower
        for peer in [p for p, t in heard.items() if t < horizon]:
            del heard[peer]
        return list(heard)

    def _serve_roster_requests(self, now: float) -> None:
        """Send the whole roster to the members that asked since the last heartbeat: to each,
        or once to everyone when many asked (after a failover every member does)."""
        if not self._roster_requests:
            return
        requesters = sorted(self._roster_requests)
        self._roster_requests.clear()
        members = {p: m.incarnation for p, m in self.members.peers.items()}
        chunks = RosterLog.chunks(
            self.epoch, self._roster_log.version, members, self.config.roster_chunk
        )
        if len(requesters) > _ROSTER_BROADCAST_FROM:
            if now < self._roster_broadcast_at:
                # A roster that changes fast (a swarm booting) is broadcast once per t_join
                # at most: the members ask again meanwhile, at no cost to anyone else.
                self._roster_requests.update(requesters)
                return
            self._roster_broadcast_at = now + self.config.t_join
        targets: list[int | None] = (
            [None] if len(requesters) > _ROSTER_BROADCAST_FROM else list(requesters)
        )
        for dst in targets:
            for chunk in chunks:
                self._emit(dst, chunk, NORMAL)

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

    def _flush_bulletins(self) -> None:
        box = self._board.outbox
        if box:
            self._board.outbox = []
            for dst, bulletin in box:
                self._emit(dst, bulletin, NORMAL)

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
