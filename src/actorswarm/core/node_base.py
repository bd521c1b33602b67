"""A platform's collective core, the layer every other builds on: its state, what it sends
(heartbeats, reliable streams, bulletins, reports) and how packets leave it (through the one
collector of :mod:`.ready`, which every part writes into).

The node is built in layers, each a class of its own module: :class:`NodeBase` (state and
output), :class:`~actorswarm.core.node_membership.NodeMembership` (who is alive),
:class:`~actorswarm.core.node_election.NodeElection` (who is master, the handshake) and
:class:`~actorswarm.core.node.Node` (the host interface, packet dispatch, the master's and
members' handling of coordination messages). A lower layer that needs a decision of an
upper one calls a method declared here and defined there.
"""

from __future__ import annotations

import math
import random
from collections import Counter

from actorswarm.core import airtime, wire
from actorswarm.core.barrier import BarrierMaster, BarrierMember, Gathers, NeedResolver, Scatter
from actorswarm.core.bulletin import BulletinBoard, BulletinInbox
from actorswarm.core.config import CoreConfig
from actorswarm.core.election import OnHeartbeat, on_heartbeat
from actorswarm.core.events import (
    AppReceived,
    DeliveryFailed,
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.membership import Membership
from actorswarm.core.ready import Collector
from actorswarm.core.reliable import Reliable
from actorswarm.core.roles import RoleMaster, RoleMember
from actorswarm.core.roster import RosterLog, RosterPool, RosterView
from actorswarm.core.wire import (
    BULLETIN_STREAM,
    NEED_ALL,
    BarrierRequest,
    BarrierStale,
    Bulletin,
    Heartbeat,
    Payload,
    Report,
    RoleClaim,
    RoleDeny,
    RoleGrant,
    RoleRelease,
    RoleRevoke,
)

MASTER_BOUND = (BarrierRequest, RoleClaim, RoleRelease, Report)
MASTER_SENT = (BarrierStale, RoleGrant, RoleDeny, RoleRevoke)
KEEP_ERRORS = 20
#: A report is sent in as many copies as keep the chance of losing them all at most this
#: (``_report_copies``), and in at most :data:`MAX_REPORT_COPIES`.
REPORT_LOST_ALL = 0.1
MAX_REPORT_COPIES = 3
#: Local health (Lifeguard): at most this many heartbeat intervals of grace for a host that
#: ticks late.
MAX_HEALTH = 8


class NodeBase:
    """State of one platform's core and its output; see the module docstring."""

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
        self._rng = rng if rng is not None else random.Random(platform)
        self._started = now
        # Everything this platform sends and reports, whichever part produced it.
        self._out = Collector(swarm=swarm, sender=platform, incarnation=incarnation)
        self.members = Membership(platform, self.config)
        self.reliable = Reliable(self.config, self._out)
        # Master to every member as one broadcast (event relays, what the master runs).
        self._board = BulletinBoard(self.config, self._out)
        self._board.retry_delay = self.reliable.retry_delay
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
        #: A star member on a shared channel does not give up its new master before this:
        #: the master's heartbeats queue behind the packets its claim set off.
        self._master_hold = -math.inf
        # The incarnation of the followed master that claimed (-1: not known yet): a
        # heartbeat of a newer one means the master rebooted and is master no more.
        self._master_incarnation = -1
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
        # Star topology (docs/design.md §3.1): the roster as the master keeps it and as members
        # copy it, the member heartbeat interval the master asks for, and the succession
        # entries presumed alive after the master was lost (platform -> presumed until).
        self._star = self.config.membership == "star"
        self.roster = RosterView(roster_pool)
        self._roster_log = RosterLog(self.config.succession)
        self._roster_requests: set[int] = set()
        self._roster_asked = -1e9
        self._roster_ask_at: float | None = None  # shared channel: a request waiting to go
        self._roster_broadcast_at = -1e9
        # Shared channel: the roster (epoch, version) of the master's last heartbeat.
        self._roster_told = (0, 0)
        self._cadence = self.config.heartbeat_interval
        #: As a star master: heartbeating twice per interval under heavy loss
        #: (``CoreConfig.fast_master_loss``).
        self._fast = False
        self._presumed: dict[int, float] = {}
        self._heard_lower: dict[int, float] = {}
        # On a shared channel: every platform heard lately, for the swarm size estimate;
        # None without a channel, where nothing needs it.
        self._heard = airtime.HeardLog(now) if self.config.channel_bitrate is not None else None
        # On a shared channel, a star member's heartbeats to a master it just followed wait
        # for its report's acknowledgement (the report's master-bound sequence number), at
        # most until ``_heartbeats_held_until``.
        self._report_seq = 0
        self._heartbeats_held_until = -math.inf
        # A master-bound message was given up: report again at the next tick.
        self._restate = False
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
        self._changes: list[MemberJoined | MemberLeft] = []  # scratch, reused per heartbeat
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

    @property
    def reports_awaited(self) -> int:
        """As master: how many members of its view have not reported in its handshake yet
        (members that join after the handshake are waited for too; ``handshake_complete``
        says only that the first round ended). 0 when not master."""
        return len(self._handshake_waiting) if self.is_master else 0

    @property
    def view(self) -> tuple[int, ...]:
        """Live platforms in this platform's view, itself included, ascending.

        A star member that follows a master sees the swarm through its master: the master's
        roster (as far as this member has it), the master and itself.
        """
        if self._following_star():
            return tuple(sorted({*self.roster.members, self.master or 0, self.platform} - {0}))
        return tuple(sorted((*self.members.peers, self.platform)))

    @property
    def view_size(self) -> int:
        """``len(self.view)``, without building the view (O(1))."""
        if self._following_star():
            roster = self.roster.members
            extra = {self.platform, self.master or 0} - {0}
            return len(roster) + sum(1 for p in extra if p not in roster)
        return len(self.members) + 1

    def _following_star(self) -> bool:
        """A star member that follows a live remote master (heartbeats to it only)."""
        return self._star and self.master is not None and not self.is_master

    @property
    def grace(self) -> float:
        """Extra patience of every leave decision: while this host ticks late, and for a
        star member on a shared channel (:meth:`_channel_patience`)."""
        return self._health * self.config.heartbeat_interval + self._channel_patience()

    def _channel_patience(self) -> float:
        """On a shared channel, how much longer a star member waits for its master's
        heartbeats: twice the time the swarm takes to put a packet each on the air (0
        otherwise). They queue behind the swarm's bursts — a barrier of all puts a request,
        its acknowledgement and a release acknowledgement of every member on the air at
        once — and a member that gives its master up for that starts a needless failover."""
        return 2 * self.reliable.channel_time if self._following_star() else 0.0

    def _default_need(self, key: int, part: int, count: int) -> int:
        return len(self.members) + 1 if count == NEED_ALL else count

    def _new_barrier_master(self) -> BarrierMaster:
        # Late-bound, so the engine may replace ``resolve_need`` after construction.
        master = BarrierMaster(
            self.config,
            resolve_need=lambda k, p, n: self.resolve_need(k, p, n),  # noqa: PLW0108
            platform=self.platform,
        )
        master.scatter = lambda k, g, chosen: self.scatter(k, g, chosen) if self.scatter else {}
        master.gathers = lambda k: self.gathers(k)  # noqa: PLW0108
        master.live = lambda p: p == self.platform or p in self.members
        master.first_retry = lambda: self.reliable.timeout(None)
        master.retry_delay = self.reliable.retry_delay
        return master

    def _set_epoch(self, epoch: int, master: int) -> None:
        if epoch < self.epoch:
            raise AssertionError(f"epoch would go back from {self.epoch} to {epoch}")
        self.epoch = epoch
        self._epoch_master = master
        self.barriers.adopt_epoch(epoch, master)
        self._max_epoch = max(self._max_epoch, epoch)

    def _decide(self, sender: int, sender_is_master: bool, sender_epoch: int) -> OnHeartbeat:
        """The election rules' answer to ``sender``'s word (a heartbeat, a Sync)."""
        return on_heartbeat(
            self_id=self.platform,
            is_master=self.is_master,
            epoch=self.epoch,
            master=self._epoch_master,
            master_alive=self.master is not None,
            sender=sender,
            sender_is_master=sender_is_master,
            sender_epoch=sender_epoch,
            master_suspected=self.master is not None and self.master in self.members.suspects,
        )

    def _report_failures(self) -> None:
        """Every message the reliable streams or the bulletin board gave up on becomes a
        DeliveryFailed event, in the order they gave up. Called at fixed points of a step
        (after the retransmission timers, after a view change), so each failure's event comes
        after the events of the step that caused it."""
        out = self._out
        if not out.failures:
            return
        for failure in out.failures:
            if failure.reason == "deadline" and isinstance(failure.payload, MASTER_BOUND):
                # A request or claim the master never acknowledged (on a lossy shared
                # channel a few retries span the whole deadline) would otherwise wait
                # unsent until the next master: the next tick reports again, and the
                # report restates everything still pending.
                self._restate = True
            reason = {
                "left": "the destination left the swarm",
                "stepped_down": "this platform stepped down as master before it was delivered",
            }.get(failure.reason, f"not acknowledged within {self.config.delivery_deadline} s")
            out.events.append(
                DeliveryFailed(dst=failure.dst, kind=type(failure.payload).__name__, reason=reason)
            )
        out.failures.clear()

    def _emit(
        self, dst: int | None, body: wire.Body, channel: int, kind: str | None = None
    ) -> None:
        """Send ``body``, numbered after what the streams and the board queued before it
        (:meth:`~actorswarm.core.ready.Collector.send`; ``kind`` labels it otherwise than
        by its type)."""
        self._out.send(dst, body, channel, kind)

    def _member_cadence(self, members: int | None = None) -> float:
        """The member heartbeat interval a star master asks for
        (:func:`~actorswarm.core.airtime.member_cadence`) for ``members`` (default: every
        other platform of :meth:`_swarm_size`)."""
        if not self._star:
            return self.config.heartbeat_interval
        others = self._swarm_size() - 1 if members is None else members
        return airtime.member_cadence(self.config, others)

    def _swarm_size(self) -> int:
        """This platform's estimate of the swarm's size, itself included: the largest of its
        view, its copy of the roster, the platforms it heard lately (on a shared channel) and,
        for a star member, the size its master's cadence implies. Before a master has heard
        its members, or a member has the roster, the platforms heard are what is known —
        at boot every platform broadcasts a heartbeat once — and a boot paced by the view
        alone would start a swarm of hundreds at 10 Hz on a channel that carries a tenth."""
        size = max(len(self.members), len(self.roster.members), len(self._heard or ()))
        if not self.is_master:  # a master's own cadence follows from this: it must not feed it
            size = max(size, airtime.implied_size(self.config, self._cadence))
        return size + 1

    def _handshake_airtime(self, members: int) -> float:
        """:func:`~actorswarm.core.airtime.handshake_airtime` of this platform's channel."""
        return airtime.handshake_airtime(self.config, members)

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
        # On the master-bound stream, in order with the claims and requests: a report made
        # before a claim must not reach the master after the claim's grant and erase it.
        self._report_seq = self.reliable.send_to_master(
            self._own_report(now), now, self.epoch, copies=self._report_copies()
        )

    def _report_copies(self) -> int:
        """How many copies of a report go out at once: enough that all are lost with a
        chance of at most :data:`REPORT_LOST_ALL` at the loss this platform measures, at
        most :data:`MAX_REPORT_COPIES`. A master decides nothing until every member has
        reported, so its handshake lasts as long as the unluckiest report's retries: among
        1000 members at 30 % loss, six or seven tries, a third of a second. Not on a shared
        channel (``channel_bitrate``), whose handshake is paced by the reports' airtime."""
        loss = self.members.loss.value
        if self.config.channel_bitrate is not None or loss <= REPORT_LOST_ALL:
            return 1
        return min(MAX_REPORT_COPIES, math.ceil(math.log(REPORT_LOST_ALL) / math.log(loss)))

    def _deliver_bulletins(self, sender: int, incarnation: int, items: list[Bulletin]) -> None:
        for item in items:
            self._out.events.append(
                AppReceived(
                    sender=sender,
                    topic=item.message.topic,
                    body=item.message.body,
                    stream=(incarnation, BULLETIN_STREAM, item.seq),
                )
            )

    # --- what the upper layers decide (NodeElection, Node) --------------------------------

    def _apply(self, action: OnHeartbeat, sender: int, epoch: int, now: float) -> bool:
        """Carry out an election decision (:class:`NodeElection`)."""
        raise NotImplementedError

    def _lose_master(self, now: float) -> None:
        """The followed master is gone (:class:`NodeElection`)."""
        raise NotImplementedError

    def _maybe_claim(self, now: float) -> None:
        """Claim the master role if the rules say so (:class:`NodeElection`)."""
        raise NotImplementedError

    def _master_joined(self, platform: int, now: float, hb: Heartbeat | None) -> None:
        """Master: a platform joined the view (:class:`NodeElection`)."""
        raise NotImplementedError

    def _finish_handshake(self, now: float) -> None:
        """Master: every member reported, or the wait is over (:class:`NodeElection`)."""
        raise NotImplementedError

    def _master_handle(self, sender: int, payload: Payload, now: float) -> None:
        """Master: a master-bound message (:class:`Node`)."""
        raise NotImplementedError

    def _member_handle(self, payload: Payload, now: float) -> None:
        """Member: a message from its master (:class:`Node`)."""
        raise NotImplementedError

    def _flush_master(self, now: float) -> None:
        """Master: send what the barrier and role tables decided (:class:`Node`)."""
        raise NotImplementedError
