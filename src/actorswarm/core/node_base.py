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

from actorswarm.core import wire
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
from actorswarm.core.roster import RosterLog, RosterView
from actorswarm.core.wire import (
    BULLETIN_STREAM,
    NEED_ALL,
    NORMAL,
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
#: A master that has more members asking for the whole roster than this at one heartbeat
#: broadcasts it once instead of sending it to each.
ROSTER_BROADCAST_FROM = 4
#: What one member's part of a new master's handshake puts on a shared channel, in
#: heartbeats' worth of bits: its report (about three), the acknowledgement, a sync when its
#: report is late, and a roster request.
HANDSHAKE_PACKETS = 6
#: On a shared channel, a platform counts the platforms it heard from within this many
#: seconds in its estimate of the swarm's size (what paces heartbeats and retransmissions
#: before a view or roster says more): long enough to span a boot, from the heartbeat every
#: platform broadcasts on starting to the first master's cadence reaching its members.
HEARD_HORIZON = 10.0
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
        self.roster = RosterView()
        self._roster_log = RosterLog(self.config.succession)
        self._roster_requests: set[int] = set()
        self._roster_asked = -1e9
        self._roster_ask_at: float | None = None  # shared channel: a request waiting to go
        self._roster_broadcast_at = -1e9
        # Shared channel: the roster (epoch, version) of the master's last heartbeat.
        self._roster_told = (0, 0)
        self._cadence = self.config.heartbeat_interval
        self._presumed: dict[int, float] = {}
        self._heard_lower: dict[int, float] = {}
        # On a shared channel: every platform heard lately (platform -> when), for the swarm
        # size estimate; None without a channel, where nothing needs it.
        self._heard: dict[int, float] | None = (
            {} if self.config.channel_bitrate is not None else None
        )
        self._heard_pruned_at = now
        # On a shared channel, a star member's heartbeats to a master it just followed wait
        # for its report's acknowledgement (the report's master-bound sequence number), at
        # most until ``_heartbeats_held_until``.
        self._report_seq = 0
        self._heartbeats_held_until = -math.inf
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
        """The member heartbeat interval a star master asks for: ``heartbeat_interval``, or
        slower when the heartbeats of its ``members`` (default: every other platform of
        :meth:`_swarm_size`) would take more than ``heartbeat_share`` of a channel of
        ``channel_bitrate``."""
        cfg = self.config
        if not self._star or cfg.channel_bitrate is None:
            return cfg.heartbeat_interval
        others = self._swarm_size() - 1 if members is None else members
        load = max(others, 1) * cfg.heartbeat_bits
        return max(cfg.heartbeat_interval, load / (cfg.heartbeat_share * cfg.channel_bitrate))

    def _swarm_size(self) -> int:
        """This platform's estimate of the swarm's size, itself included: the largest of its
        view, its copy of the roster, the platforms it heard lately (on a shared channel) and,
        for a star member, the size its master's cadence implies. Before a master has heard
        its members, or a member has the roster, the platforms heard are what is known —
        at boot every platform broadcasts a heartbeat once — and a boot paced by the view
        alone would start a swarm of hundreds at 10 Hz on a channel that carries a tenth."""
        size = max(len(self.members), len(self.roster.members), len(self._heard or ()))
        cfg = self.config
        member = not self.is_master
        if member and cfg.channel_bitrate is not None and self._cadence > cfg.heartbeat_interval:
            # cadence = others × bits / (share × bitrate), inverted (a master's own cadence
            # follows from this estimate: it must not feed it)
            share = cfg.heartbeat_share * cfg.channel_bitrate
            size = max(size, int(self._cadence * share / cfg.heartbeat_bits))
        return size + 1

    def _prune_heard(self, now: float) -> None:
        """Forget the platforms not heard within :data:`HEARD_HORIZON` (once a second)."""
        heard = self._heard
        if heard is None or now - self._heard_pruned_at < 1.0:
            return
        self._heard_pruned_at = now
        horizon = now - HEARD_HORIZON
        for peer in [p for p, t in heard.items() if t < horizon]:
            del heard[peer]

    def _handshake_airtime(self, members: int) -> float:
        """On a shared channel (``channel_bitrate``), how long the packets a claim sets off
        take on the air: each of ``members`` reports, is acknowledged, may be sent a sync and
        heartbeats meanwhile — about :data:`HANDSHAKE_PACKETS` heartbeats' worth each, in the
        half of the channel the heartbeats leave. 0 without a channel."""
        cfg = self.config
        if cfg.channel_bitrate is None:
            return 0.0
        bits = members * HANDSHAKE_PACKETS * cfg.heartbeat_bits
        return bits / ((1.0 - cfg.heartbeat_share) * cfg.channel_bitrate)

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
        self._prune_heard(now)
        # On a shared channel the roster of a new epoch is broadcast unasked
        # (:meth:`_roster_outrun`), after the claim's heartbeat: a member takes a roster
        # only from the master it follows.
        roster_after = (
            self.config.channel_bitrate is not None and self._roster_told[0] != self.epoch
        )
        if self.is_master and self._star:
            self._cadence = self._member_cadence()
            self.members.cadence = self._cadence
            if not roster_after:
                self._serve_roster_requests(now)
        bitrate = self.config.channel_bitrate
        if bitrate is not None:
            # What the swarm needs to put one packet each on the shared channel: reliable
            # delivery waits at least that long for an acknowledgement.
            self.reliable.channel_time = self._swarm_size() * self.config.heartbeat_bits / bitrate
        hb = self._heartbeat(now)
        if self._following_star():
            if self._heartbeats_held(now):
                self.counters["heartbeat_held"] += 1
            else:
                self._emit(self.master, hb, NORMAL)
        elif self._quiet(now) and not (self._hb_count == 1 and self._heard is not None):
            # On a shared channel the first heartbeat goes out all the same: one packet per
            # platform, and every platform hears how many there are (:meth:`_swarm_size`)
            # before the first claim asks all of them to report at once.
            self.counters["heartbeat_quiet"] += 1
        else:
            self._emit(None, hb, NORMAL)
        if roster_after and self.is_master and self._star:
            self._serve_roster_requests(now)

    def _heartbeats_held(self, now: float) -> bool:
        """On a shared channel, a star member heartbeats to a master it just followed only
        once its report is acknowledged: a claim at boot sets off a report from every
        platform before the master knows how many there are and can ask for a cadence, and
        members heartbeating at 10 Hz meanwhile would fill the channel its heartbeats need
        (docs/collective-core.md, "Airtime"). By then the master has counted the reports it
        received, and its heartbeat carries a cadence for them."""
        return now < self._heartbeats_held_until and self.reliable.master_holds(self._report_seq)

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

    def _roster_outrun(self) -> bool:
        """On a shared channel: the roster changed since the master's last heartbeat by
        more than a heartbeat's changes can tell (a new epoch, a swarm joining by the
        hundred), so every member is behind — one broadcast of the roster serves them all,
        and saves the channel a request from each. Notes the version told."""
        log = self._roster_log
        told_epoch, told_version = self._roster_told
        self._roster_told = (self.epoch, log.version)
        if self.config.channel_bitrate is None or not self.members:
            return False
        return told_epoch != self.epoch or log.version - told_version > wire.MAX_CHANGES

    def _serve_roster_requests(self, now: float) -> None:
        """Send the whole roster to the members that asked since the last heartbeat: to each,
        or once to everyone when many asked (after a failover every member does) or, on a
        shared channel, when all of them are behind (:meth:`_roster_outrun`)."""
        outrun = self._roster_outrun()
        if not self._roster_requests and not (outrun and now >= self._roster_broadcast_at):
            return
        requesters = sorted(self._roster_requests)
        self._roster_requests.clear()
        members = {p: m.incarnation for p, m in self.members.peers.items()}
        chunks = RosterLog.chunks(
            self.epoch, self._roster_log.version, members, self.config.roster_chunk
        )
        if outrun or len(requesters) > ROSTER_BROADCAST_FROM:
            if now < self._roster_broadcast_at:
                # A roster that changes fast (a swarm booting) is broadcast once per t_join
                # at most: the members ask again meanwhile, at no cost to anyone else.
                self._roster_requests.update(requesters)
                return
            self._roster_broadcast_at = now + self.config.t_join
        targets: list[int | None] = (
            [None] if outrun or len(requesters) > ROSTER_BROADCAST_FROM else list(requesters)
        )
        for dst in targets:
            for chunk in chunks:
                self._emit(dst, chunk, NORMAL)

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
        self._report_seq = self.reliable.send_to_master(self._own_report(now), now, self.epoch)

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
