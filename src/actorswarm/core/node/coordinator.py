"""One platform's collective core: the sans-IO object every host drives.

Theory of operation
-------------------
A host (the simulator, the daemon) owns a :class:`Node` and does three things with it:

* hands it every packet that arrives, checked and decoded by the host's
  :class:`~actorswarm.security.pipeline.Pipeline` (its guard refuses a bad frame, a bad
  tag or a replay before the body is decoded): :meth:`Node.receive_packet`, the one way in;
* calls :meth:`Node.tick` no later than :meth:`Node.next_deadline`;
* after each of these (and each application call) takes :meth:`Node.ready`, the one way
  out: a :class:`~.ready.Ready` holding the packets to send (``dst`` None is a broadcast)
  and the events to read, everything at once. :attr:`Node.has_ready` says whether there is
  any.

The application (task engine, tests) asks for coordination with :meth:`request_barrier`,
:meth:`claim_role`, :meth:`release_role` and :meth:`send_app`. Every call takes ``now``; the
node reads no clock, opens no socket, starts no thread and draws randomness only from the
seeded ``rng`` it was given (the phase of its heartbeats).

Inside, the node composes membership (:mod:`actorswarm.core.membership.view`), election
(:mod:`actorswarm.core.election`), reliable streams (:mod:`actorswarm.core.delivery.reliable`),
bulletins (:mod:`actorswarm.core.delivery.bulletin`), barriers (:mod:`actorswarm.core.barrier`) and
roles (:mod:`actorswarm.core.roles`). Each part writes what it sends and reports into the
node's one collector (:mod:`actorswarm.core.ready`). The node keeps the state its parts
share (whom it follows, in which epoch) and hands the work to them as objects, each
keeping the state that only it uses and handed the collaborators it needs (the collector,
the master's tables, the bulletin board and inbox, the :class:`~.failures.Failures` it
reports into, the parts made before it) when it is made:
:class:`~.liveness.Liveness` (who is alive: heartbeats, probes, view changes),
:class:`~.rostersync.RosterSync` (a star swarm's roster, served and followed),
:class:`~.leadership.Leadership` (who is master: claims, following, stepping down,
reports; the :class:`~.handshake.Handshake`), :class:`~.intake.Intake` (what a received
packet's body is handed to) and its role, :class:`~.duties.MasterDuties` or
:class:`~.duties.MemberDuties`, swapped when it claims or steps down, both acting on the
master's barrier and role tables (:class:`~.tables.MasterTables`).
Master-bound messages are sent to the current master — or handled in place when this platform
is the master — and wait, in order, while there is none. Packets that fail any check are
dropped and counted in :attr:`Node.counters`, never raised: untrusted bytes cannot crash a
platform nor change its state.
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Iterable
from typing import Any

from actorswarm.core import wire
from actorswarm.core.barrier import (
    BarrierMaster,
    BarrierMember,
    Gathers,
    NeedResolver,
    Scatter,
)
from actorswarm.core.config import CoreConfig
from actorswarm.core.delivery.bulletin import BulletinBoard, BulletinInbox
from actorswarm.core.delivery.reliable import Reliable
from actorswarm.core.events import (
    AppReceived,
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.membership import airtime
from actorswarm.core.membership.roster import RosterPool, RosterView
from actorswarm.core.membership.view import Membership
from actorswarm.core.node.duties import Duties, MasterDuties, MemberDuties
from actorswarm.core.node.failures import Failures
from actorswarm.core.node.intake import _BODY_HANDLERS, Intake
from actorswarm.core.node.leadership import Leadership
from actorswarm.core.node.liveness import Liveness
from actorswarm.core.node.outbox import MasterOutbox
from actorswarm.core.node.rostersync import RosterSync
from actorswarm.core.node.tables import MasterTables
from actorswarm.core.ready import Collector, Outgoing, Ready
from actorswarm.core.roles import RoleMember
from actorswarm.core.wire import (
    NEED_ALL,
    NORMAL,
    URGENT,
    AppMessage,
    Heartbeat,
    Packet,
    RoleRelease,
)

#: Unexpected internal errors kept for diagnosis (:attr:`Node.errors`).
KEEP_ERRORS = 20


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
        roster_pool: RosterPool | None = None,
    ) -> None:
        if not 1 <= platform <= wire.MAX_PLATFORM:
            raise ValueError(f"platform ID must be 1..{wire.MAX_PLATFORM}, got {platform}")
        if incarnation < 0:
            raise ValueError(f"incarnation must be >= 0, got {incarnation}")
        self.platform = platform
        self.swarm = swarm
        self.incarnation = incarnation
        self.config = config or CoreConfig()
        rng = rng if rng is not None else random.Random(platform)
        self._started = now
        # Everything this platform sends and reports, whichever part produced it.
        self._out = Collector(swarm=swarm, sender=platform, incarnation=incarnation)
        self.members = Membership(platform, self.config)
        self.reliable = Reliable(self.config, self._out)
        # Master to every member as one broadcast (event relays, what the master runs).
        self._board = BulletinBoard(self.config, self._out)
        self._board.retry_delay = self.reliable.retry_delay
        self._inbox = BulletinInbox(platform)
        self.barriers = BarrierMember(platform)
        self.roles = RoleMember()
        # The master's barrier and role tables (kept across roles).
        self._tables = MasterTables(platform, self._new_barrier_master)
        # Election state: ``epoch`` is the one this platform is in (who claimed it:
        # :attr:`.leadership.Leadership.epoch_master`); ``master`` is whom we follow now (None
        # while we have lost it).
        self.epoch = 0
        self.master: int | None = None
        self.is_master = False
        self.handshake_complete = False
        self._awake = False
        # Star topology (docs/design.md §3.1): the roster as members copy it (the master's
        # own is :attr:`.rostersync.RosterSync.log`).
        self.roster = RosterView(roster_pool)
        # On a shared channel: every platform heard lately, for the swarm size estimate;
        # None without a channel, where nothing needs it.
        self._heard = airtime.HeardLog(now) if self.config.channel_bitrate is not None else None
        # What the streams and the board gave up on, told as events.
        self._failures = Failures(self._out, self.config)
        self.counters: Counter[str] = Counter()
        #: Unexpected internal errors caught at the packet boundary (kept for diagnosis;
        #: tests require it to stay empty).
        self.errors: list[str] = []
        #: Hook for the task engine: what part ``part`` of barrier ``key`` waits for, given
        #: its need (a number or NEED_ALL): :data:`~actorswarm.core.barrier.NeedResolver`.
        #: Default: the number asked for, and every live platform in the master's view for
        #: NEED_ALL.
        self.resolve_need: NeedResolver = self._default_need
        #: Hook for the task engine: per-participant data a release scatters (default: none,
        #: each participant learns only its index). Used whenever this platform is master.
        self.scatter: Scatter | None = None
        #: Hook for the task engine: whether a release of a key carries every chosen
        #: participant's request data to all (default: yes; the engine's transitions say no,
        #: their data is read by the master's ``scatter`` alone).
        self.gathers: Gathers = lambda key: True
        # The parts that act on this state: who is alive, and who is master (each handed
        # the parts made before it that it calls).
        self._rosters = RosterSync(self, self._out, rng, failures=self._failures)
        self._live = Liveness(
            self, self._out, now, rng, self._heard, rosters=self._rosters, failures=self._failures
        )
        self._lead = Leadership(
            self,
            self._out,
            self._tables,
            self._board,
            self._inbox,
            now,
            live=self._live,
            rosters=self._rosters,
        )
        # The role: what this platform does as master or as member, swapped by
        # :meth:`_take_role` (``is_master`` says which one it holds).
        self._member_duties = MemberDuties(
            self, self._out, self._tables, lead=self._lead, live=self._live
        )
        self._master_duties = MasterDuties(
            self,
            self._out,
            self._tables,
            self._board,
            lead=self._lead,
            live=self._live,
            rosters=self._rosters,
            member=self._member_duties,
        )
        self._intake = Intake(
            self,
            self._out,
            self._board,
            self._inbox,
            lead=self._lead,
            rosters=self._rosters,
            member=self._member_duties,
        )
        self._role: Duties = self._member_duties

    @property
    def reports_awaited(self) -> int:
        """As master: how many members of its view have not reported in its handshake yet
        (members that join after the handshake are waited for too; ``handshake_complete``
        says only that the first round ended). 0 when not master."""
        return self._role.reports_awaited()

    @property
    def view(self) -> tuple[int, ...]:
        """Live platforms in this platform's view, itself included, ascending.

        A star member that follows a master sees the swarm through its master: the master's
        roster (as far as this member has it), the master and itself.
        """
        if self._live.following_star():
            return tuple(sorted({*self.roster.members, self.master or 0, self.platform} - {0}))
        return tuple(sorted((*self.members.peers, self.platform)))

    @property
    def view_size(self) -> int:
        """``len(self.view)``, without building the view (O(1))."""
        if self._live.following_star():
            roster = self.roster.members
            extra = {self.platform, self.master or 0} - {0}
            return len(roster) + sum(1 for p in extra if p not in roster)
        return len(self.members) + 1

    @property
    def grace(self) -> float:
        """Extra patience of every leave decision: while this host ticks late, and for a
        star member on a shared channel (:attr:`.liveness.Liveness.grace`)."""
        return self._live.grace

    def _default_need(self, key: int, part: int, count: int) -> int:
        return len(self.members) + 1 if count == NEED_ALL else count

    def _new_barrier_master(self, outbox: MasterOutbox) -> BarrierMaster:
        # Late-bound, so the engine may replace its hooks after construction.
        return BarrierMaster(
            self.config,
            outbox,
            resolve_need=lambda k, p, n: self.resolve_need(k, p, n),  # noqa: PLW0108
            platform=self.platform,
            scatter=lambda k, g, chosen: self.scatter(k, g, chosen) if self.scatter else {},
            gathers=lambda k: self.gathers(k),  # noqa: PLW0108
            live=lambda p: p == self.platform or p in self.members,
            first_retry=lambda: self.reliable.timeout(None),
            retry_delay=self.reliable.retry_delay,
        )

    def _take_role(self, role: Duties) -> None:
        """Become master (:class:`~.duties.MasterDuties`) or member
        (:class:`~.duties.MemberDuties`): the one place ``is_master`` changes."""
        self._role = role
        self.is_master = role.is_master

    def ready(self) -> Ready:
        """Everything to send and to read since the last call, taken at once: packets
        (ground-station channel first, then in the order they were numbered) and events (in
        the order they happened). The node holds no output afterwards."""
        return self._out.take()

    @property
    def has_ready(self) -> bool:
        """Whether :meth:`ready` would return anything.

        A host may skip :meth:`next_deadline` after a :meth:`receive_packet` that left no
        output: a packet that makes the node send or report nothing never brings a deadline
        forward (at 1000 platforms this saves a call per heartbeat heard).
        """
        return self._out.pending

    def due(self, now: float) -> bool:
        """Whether a host awake at ``now`` should :meth:`tick`: a deadline has passed, or
        is within ``heartbeat_slack`` (a heartbeat then goes out on this wake instead of
        at a wake of its own; see :class:`~actorswarm.core.config.CoreConfig`)."""
        deadline = self.next_deadline()
        if deadline is not None and deadline <= now + (self.config.heartbeat_slack or 0.0):
            return True
        return self._live.heartbeat_due(now)

    def next_deadline(self) -> float | None:
        """The latest time by which :meth:`tick` must be called next."""
        best = self._live.next_heartbeat
        members_due = self.members.next_deadline()
        for t in (
            None if members_due is None else members_due + self.grace,
            self._live.next_probe(),
            self._lead.presumed_until(),
            self.reliable.next_deadline(),
            *self._role.deadlines(),
            *self._lead.handshake.deadlines(),
        ):
            if t is not None and t < best:
                best = t
        if not self._awake:
            best = min(best, self._started + self.config.startup_wait)
        master_due = self._live.master_deadline()
        if master_due is not None:
            best = min(best, master_due)
        self._live.expect_tick(best)
        return best

    def receive_packet(self, packet: Packet, now: float) -> None:
        """Accept a packet the host's pipeline checked and decoded
        (:meth:`~actorswarm.security.pipeline.Pipeline.receive`): the node's one way in.
        Never raises; a packet that fails a check here is counted."""
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
        self._live.check_health(now)
        joined_left: list[MemberJoined | MemberLeft] = []
        suspected: list[int] = []
        self.members.expire(now, joined_left, suspected, self.grace)
        self._live.suspected(suspected, now)
        self._live.membership_changed(joined_left, now)
        self._live.probe(now)
        if self._live.master_unheard_since(now):
            self._lead.lose_master(now)
        self._lead.expire_presumed(now)
        self._lead.maybe_claim(now)
        self._role.tick(now)
        self.reliable.tick(now)
        self._failures.report()
        if self._failures.take_restate():
            self._role.restate(now)
        self._live.heartbeat_tick(now)

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
            master=self._lead.epoch_master or 0,
            renew=renew,
        )
        self._role.to_master(req, now)
        return req.generation

    def claim_role(self, role: str, quota: int, now: float, *, bid: float | None = None) -> None:
        """Claim ``role`` (at most ``quota`` holders); answered by RoleGranted/RoleDenied."""
        claim = self.roles.claim(role, quota, float(self.platform if bid is None else bid))
        if role not in self.roles.held:
            self._role.to_master(claim, now)

    def release_role(self, role: str, now: float) -> None:
        if self.roles.release(role):
            self._role.to_master(RoleRelease(role=role), now)

    def send_app(
        self, dst: int | None, topic: str, body: bytes, now: float, *, urgent: bool = False
    ) -> None:
        """Send an application message reliably to ``dst`` (None: the master)."""
        msg = AppMessage(topic=topic, body=body)
        channel = URGENT if urgent else NORMAL
        if dst is None:
            self._role.app_to_master(msg, now)
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
        self._role.post_bulletin(AppMessage(topic=topic, body=body), now, skip)

    def needs_changed(self, now: float, keys: Iterable[int] | None = None) -> None:
        """Master: what the parts of barriers ``keys`` (None: all) wait for may have changed
        (the task engine learnt that a platform entered or left an actor): fire what is now
        complete."""
        self._role.needs_changed(now, keys)

    def waiting_occasions(self, key: int) -> tuple[str, ...]:
        """Master: the occasions of the requests waiting at barrier ``key`` (none on a
        member)."""
        return self._role.waiting_occasions(key)

    def hold_barrier(self, key: int, until: float) -> None:
        """Master only: fire nothing of barrier ``key`` before ``until``, so that requests
        on their way are chosen by their bids rather than by who arrives first
        (:meth:`~actorswarm.core.barrier.BarrierMaster.hold`). Elsewhere it does nothing."""
        self._role.hold_barrier(key, until)

    def role_holders(self, role: str) -> tuple[int, ...]:
        """Master only: who holds ``role`` according to the master's table."""
        return self._tables.roles.holders(role)

    def _dispatch(self, packet: Packet, now: float) -> None:
        body = packet.body
        if self._heard is not None and packet.sender != wire.GROUND_STATION:
            self._heard.heard(packet.sender, now)
        if type(body) is Heartbeat:
            self._live.on_heartbeat(packet.sender, packet.incarnation, body, now, packet.seq)
            return
        if packet.sender != wire.GROUND_STATION and self.members.is_newer(
            packet.sender, packet.incarnation
        ):
            # A rebooted peer's first packet may come before its first heartbeat: the old
            # incarnation leaves first, so nothing granted to the new one is taken back.
            left: list[MemberJoined | MemberLeft] = []
            self.members.note_incarnation(packet.sender, packet.incarnation, left)
            self._live.membership_changed(left, now)
        _BODY_HANDLERS[type(body)](self._intake, packet, now)


__all__ = ["Node", "Outgoing", "Ready"]
