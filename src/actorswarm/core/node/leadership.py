"""Who is master, as one node sees it: claiming, following and stepping down, the loss of
the master and its succession, the handshake and the reports that feed it (the decisions
themselves are the rules of :mod:`actorswarm.core.election`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from actorswarm.core.election import OnHeartbeat, on_heartbeat, should_claim
from actorswarm.core.events import (
    BecameMaster,
    HandshakeComplete,
    MasterChanged,
    SteppedDown,
)
from actorswarm.core.node.handshake import Handshake
from actorswarm.core.wire import (
    BarrierRequest,
    Heartbeat,
    Report,
    RoleClaim,
    RoleRelease,
    Sync,
)

if TYPE_CHECKING:
    from actorswarm.core.delivery.bulletin import BulletinBoard, BulletinInbox
    from actorswarm.core.node.coordinator import Node
    from actorswarm.core.node.liveness import Liveness
    from actorswarm.core.node.rostersync import RosterSync
    from actorswarm.core.node.tables import MasterTables
    from actorswarm.core.ready import Collector

#: Master-bound messages: sent to the master over its stream (or handled in place by it).
MASTER_BOUND = (BarrierRequest, RoleClaim, RoleRelease, Report)
#: A report is sent in as many copies as keep the chance of losing them all at most this
#: (``_report_copies``), and in at most :data:`MAX_REPORT_COPIES`.
REPORT_LOST_ALL = 0.1
MAX_REPORT_COPIES = 3


class Leadership:
    """Who is master, for one :class:`~actorswarm.core.node.Node`: see the module
    docstring. It acts on the node's election state (``epoch``, ``master``,
    ``is_master``) and keeps its own: who claimed the epoch, the highest epoch seen, the
    best claim heard, the followed master's incarnation, the successors presumed alive,
    the held heartbeats and, as master, the :class:`~.handshake.Handshake`. The node asks
    it (:meth:`decide`, :meth:`presumed_until`, :attr:`epoch_master`) rather than reading
    that state."""

    def __init__(
        self,
        node: Node,
        out: Collector,
        tables: MasterTables,
        board: BulletinBoard,
        inbox: BulletinInbox,
        now: float,
        *,
        live: Liveness,
        rosters: RosterSync,
    ) -> None:
        self._node = node
        self._live = live  # the node's liveness: heartbeats, probes, cadence, airtime
        self._rosters = rosters  # the star roster: reset on a claim, requests dropped
        self._star = node.config.membership == "star"  # a star swarm (docs/design.md §3.1)
        self._board = board  # the node's bulletin board (master to every member)
        self._inbox = inbox  # the node's bulletin inbox (from the master it follows)
        self._started = now  # when the node started: it listens a while before it claims
        self._tables = tables  # the master's tables (the node's, kept across roles)
        self._out = out  # the node's collector: what this part sends and reports
        # Who claimed the node's epoch (None: nobody yet; kept after the master is lost).
        self._epoch_master: int | None = None
        # The highest epoch seen, and the best claim heard while the master was still
        # trusted: (epoch, sender, heard at).
        self._max_epoch = 0
        self._best_claim: tuple[int, int, float] | None = None
        # The incarnation of the followed master that claimed (-1: not known yet): a
        # heartbeat of a newer one means the master rebooted and is master no more.
        self._master_incarnation = -1
        # Star: the succession entries presumed alive after the master was lost (platform ->
        # presumed until).
        self._presumed: dict[int, float] = {}
        # Since when this platform has elected as in broadcast mode (no master, no presumed
        # successor): only then may a platform outside the succession list claim.
        self._listening_since = now
        # On a shared channel, a star member's heartbeats to a master it just followed wait
        # for its report's acknowledgement (the report's master-bound sequence number), at
        # most until ``_heartbeats_held_until`` (:meth:`holds_heartbeats`).
        self._report_seq = 0
        self._heartbeats_held_until = -math.inf
        #: The handshake of this platform's epoch as master (closed otherwise).
        self.handshake = Handshake()

    @property
    def epoch_master(self) -> int | None:
        """Who claimed the epoch this platform is in (None: nobody yet). Unlike
        ``Node.master`` it stays known after the master is lost."""
        return self._epoch_master

    def decide(
        self, sender: int, sender_is_master: bool, sender_epoch: int, sender_master: int = 0
    ) -> OnHeartbeat:
        """The election rules' answer to ``sender``'s word (a heartbeat, a Sync);
        ``sender_master``: whom it follows (0: none, or not said)."""
        node = self._node
        return on_heartbeat(
            self_id=node.platform,
            is_master=node.is_master,
            epoch=node.epoch,
            master=self._epoch_master,
            master_alive=node.master is not None,
            sender=sender,
            sender_is_master=sender_is_master,
            sender_epoch=sender_epoch,
            master_suspected=node.master is not None and node.master in node.members.suspects,
            sender_master=sender_master,
        )

    def demoted(self, sender: int, its_master: int, now: float) -> None:
        """My master ``sender`` gave up, and follows ``its_master`` (0: none): the master is
        lost, and the epoch's master is the one it follows, if any."""
        node = self._node
        self.lose_master(now)
        if its_master not in (0, node.platform, sender):
            self._epoch_master = its_master

    def _set_epoch(self, epoch: int, master: int) -> None:
        node = self._node
        if epoch < node.epoch:
            raise AssertionError(f"epoch would go back from {node.epoch} to {epoch}")
        node.epoch = epoch
        self._epoch_master = master
        node.barriers.adopt_epoch(epoch, master)
        self._max_epoch = max(self._max_epoch, epoch)

    def saw_epoch(self, epoch: int) -> None:
        """A heartbeat or Sync told of ``epoch``: a claim of this platform's goes above it."""
        self._max_epoch = max(self._max_epoch, epoch)

    def heard_claim(self, sender: int, claims: bool, epoch: int, now: float) -> None:
        """``sender`` claims (``claims``) ``epoch``, and the rules say to ignore it while the
        master is trusted: kept, if above this platform's epoch and every claim heard, to
        follow at once should the master be lost (:meth:`lose_master`)."""
        better = self._best_claim is None or epoch > self._best_claim[0]
        if claims and epoch > self._node.epoch and better:
            self._best_claim = (epoch, sender, now)

    def master_incarnation_heard(self, incarnation: int, claims: bool, now: float) -> None:
        """The followed master heartbeats in ``incarnation`` (as master: ``claims``): a newer
        one than the one that claimed means it rebooted, and is master no more."""
        if incarnation > self._master_incarnation >= 0:
            # The new incarnation claims nothing (a heartbeat of an older epoch would
            # otherwise pass for a late one from before its claim).
            self._node.counters["master_restarted"] += 1
            self.lose_master(now)
        elif claims:
            self._master_incarnation = incarnation

    def followed_in(self, incarnation: int) -> None:
        """The master just followed heartbeats in ``incarnation``: known from its first
        heartbeat, so that its reboot is noticed even if that is the last one heard."""
        self._master_incarnation = incarnation

    def presumed_until(self) -> float | None:
        """When the first successor presumed alive is presumed no more (None: none is)."""
        return min(self._presumed.values(), default=None)

    def presumes_lower(self) -> bool:
        """Whether a successor with a lower ID than this platform's is presumed alive."""
        platform = self._node.platform
        return any(p < platform for p in self._presumed)

    def expire_presumed(self, now: float) -> None:
        """Successors presumed alive until ``now`` are no more; with none left, this
        platform elects as in broadcast mode from now on."""
        if self._presumed:
            self._presumed = {p: t for p, t in self._presumed.items() if t > now}
            if not self._presumed:
                self._listening_since = now

    def holds_heartbeats(self, now: float) -> bool:
        """On a shared channel: whether a star member's heartbeats to the master it just
        followed still wait for its report's acknowledgement (at most until a deadline)."""
        node = self._node
        return now < self._heartbeats_held_until and node.reliable.master_holds(self._report_seq)

    def _own_report(self, now: float) -> Report:
        node = self._node
        return Report(
            epoch=node.epoch,
            generations=dict(node.barriers.known),
            pending=node.barriers.restated(now),
            # A former master also reports the firings it decided (its barrier table is
            # kept until it claims again).
            released=node.barriers.records() + node._role.own_releases(),
            held=list(node.roles.held.values()),
            claims=list(node.roles.claims.values()),
        )

    def report(self, now: float) -> None:
        node = self._node
        if node.master is None or node.master == node.platform:
            return
        # On the master-bound stream, in order with the claims and requests: a report made
        # before a claim must not reach the master after the claim's grant and erase it.
        self._report_seq = node.reliable.send_to_master(
            self._own_report(now), now, node.epoch, copies=self._report_copies()
        )

    def _report_copies(self) -> int:
        """How many copies of a report go out at once: enough that all are lost with a
        chance of at most :data:`REPORT_LOST_ALL` at the loss this platform measures, at
        most :data:`MAX_REPORT_COPIES`. A master decides nothing until every member has
        reported, so its handshake lasts as long as the unluckiest report's retries: among
        1000 members at 30 % loss, six or seven tries, a third of a second. Not on a shared
        channel (``channel_bitrate``), whose handshake is paced by the reports' airtime."""
        node = self._node
        loss = node.members.loss.value
        if node.config.channel_bitrate is not None or loss <= REPORT_LOST_ALL:
            return 1
        return min(MAX_REPORT_COPIES, math.ceil(math.log(REPORT_LOST_ALL) / math.log(loss)))

    def on_sync(self, sender: int, sync: Sync, now: float, incarnation: int = -1) -> None:
        node = self._node
        self._max_epoch = max(self._max_epoch, sync.epoch)
        self._sync_bulletins(sender, sync)
        if sender == node.master and sync.epoch == node.epoch:
            self._master_incarnation = max(self._master_incarnation, incarnation)
            self.report(now)
            return
        action = self.decide(sender, True, sync.epoch)
        if not self.apply(action, sender, sync.epoch, now):
            node.counters["drop:stale_epoch"] += 1
        if node.master == sender:
            self._master_incarnation = incarnation
        self._sync_bulletins(sender, sync)

    def _sync_bulletins(self, sender: int, sync: Sync) -> None:
        """The master's handshake says where this platform's part of its bulletins begins."""
        node = self._node
        if sender != node.master or not sync.bulletin:
            return
        node._intake.deliver_bulletins(
            sender, self._inbox.incarnation, self._inbox.start(sync.bulletin)
        )

    def apply(self, action: OnHeartbeat, sender: int, epoch: int, now: float) -> bool:
        """Carry out an election decision about ``sender``'s claim of ``epoch``; False when
        the decision is left to the caller (IGNORE, DEMOTED)."""
        node = self._node
        if action is OnHeartbeat.FOLLOW:
            self._follow(sender, epoch, now)
        elif action is OnHeartbeat.STEP_DOWN:
            self._step_down(sender, now)
            if epoch > node.epoch:
                self._follow(sender, epoch, now)
        elif action is OnHeartbeat.RECLAIM:
            self._claim(now)
        else:
            return False
        return True

    def master_joined(self, platform: int, now: float, hb: Heartbeat | None) -> None:
        """A platform joined the master's view. One that already reported in this epoch
        (it followed the claim before its heartbeats made it join) needs nothing more. One
        that reported and was then declared gone (a false alarm) is asked to report again —
        its pending requests were dropped with it — but holds nothing back: everything it
        knows it learnt from this master. Anyone else (a newcomer, the other side of a healed
        partition) must follow and report, and until it has, the master decides nothing,
        since the report may show a firing to complete."""
        node = self._node
        handshake = self.handshake
        if handshake.has_reported(platform):
            return
        rejoining = (
            handshake.forget_rejoining(platform)
            and hb is not None
            and hb.epoch == node.epoch
            and hb.master == node.platform
        )
        sync = Sync(epoch=node.epoch, bulletin=self._board.next_seq)
        node.reliable.send(platform, sync, now, node.epoch)
        if rejoining:
            node.counters["rejoined"] += 1
            return
        handshake.wait_for(platform, now, node.config.handshake_timeout)
        self._tables.barriers.topology_changed(now)
        self._tables.hold()

    def maybe_claim(self, now: float) -> None:
        node = self._node
        lowest = self._live.lowest_peer
        listened = now - self._started
        if self._star and node.master is None and not node.is_master:
            # A star platform also counts the lower IDs it heard but that have not joined its
            # view (they keep quiet only if they hear someone lower still) and the successors
            # it presumes alive. The first live successor takes over at once; anyone else
            # elects as in broadcast mode, having listened for ``startup_wait`` first.
            lower = [p for p in self._presumed if p < node.platform]
            lower += self._live.lower_heard(now)
            if lower:
                lowest = min(lower) if lowest is None else min(lowest, *lower)
            if node.platform not in node.roster.succession:
                listened = min(listened, now - self._listening_since)
        if should_claim(
            self_id=node.platform,
            lowest_peer=lowest,
            is_master=node.is_master,
            master=node.master,
            master_alive=node.master is not None,
            takeover_on_join=node.config.takeover_on_join,
            listened=listened,
            startup_wait=node.config.startup_wait,
        ):
            self._claim(now)

    def _claim(self, now: float) -> None:
        """Become master in a new epoch above every epoch seen; start the handshake."""
        node = self._node
        self._max_epoch += 1
        predecessor = self._epoch_master
        self._set_epoch(self._max_epoch, node.platform)
        node.master = node.platform
        self._inbox.follow(None)
        self.handshake.restart(self._board.next_seq)
        self._presumed.clear()
        self._live.forget_probes()
        if not node.is_master:
            node._take_role(node._master_duties)
            # This term's tables start empty, but for the firings it decided in an earlier
            # one (:meth:`~.tables.MasterTables.new_term` says why).
            self._tables.new_term()
            if self._star:
                # The predecessor's roster: those platforms were members a moment ago. They
                # are watched from now on and waited for in the handshake, and those that do
                # not answer leave like any silent member — at the cadence they will be
                # asked for, and on a shared channel only once the handshake's packets
                # have had their airtime: their first heartbeats queue behind them.
                inherited = [
                    (p, i)
                    for p, i in node.roster.members.items()
                    if p not in (predecessor, node.platform)
                ]
                node.members.cadence = self._live.member_cadence(
                    max(len(inherited), self._live.swarm_size() - 1)
                )
                grace = self._live.handshake_airtime(len(inherited))
                for peer, incarnation in inherited:
                    node.members.admit(peer, incarnation, now, grace=grace)
                self._live.recount_lowest_peer()
        else:  # a new epoch while master: everyone reports again, nothing fires meanwhile
            self._tables.hold()
            # On a shared channel the members' heartbeats now queue behind their reports
            # (and wait for their acknowledgement) as after any claim.
            hold = now + self._live.handshake_airtime(len(node.members))
            for peer in list(node.members.peers) if hold > now else ():
                node.members.hold(peer, hold, now)
        self._rosters.log.reset(node.epoch)
        self._live.set_cadence(self._live.member_cadence())
        node.handshake_complete = False
        self._tables.barriers.topology_changed(now)
        self._out.events.append(BecameMaster(epoch=node.epoch))
        self._out.events.append(MasterChanged(master=node.platform, epoch=node.epoch))
        node.reliable.retarget(None, now)
        waiting = set(node.members.peers)
        # Members follow the claim heartbeat and report on their own; a Sync goes only to
        # those who have not reported after a round trip's worth of retry delay.
        # On a shared channel the reports queue behind each other: no sync before they had
        # their airtime.
        self.handshake.open(
            waiting,
            deadline=now + node.config.handshake_timeout,
            sync_at=now
            + max(2 * node.config.retry_base, self._live.handshake_airtime(len(waiting))),
        )
        self._live.send_heartbeat(now)
        # The master's own state counts like any member's report.
        node._master_duties.decide(node.platform, self._own_report(now), now)
        for payload in node.reliable.take_unrouted():
            node._master_duties.decide(node.platform, payload, now)
        if not self.handshake.awaited:
            self.finish_handshake(now)

    def finish_handshake(self, now: float) -> None:
        node = self._node
        if self.handshake.close():
            node.counters["handshake_incomplete"] += 1
        if not node.handshake_complete:
            node.handshake_complete = True
            self._out.events.append(HandshakeComplete(epoch=node.epoch, members=len(node.members)))
        self._tables.become_ready(now, node.epoch)
        node._master_duties.flush(now)

    def _step_down(self, to: int, now: float) -> None:
        node = self._node
        node._take_role(node._member_duties)
        self._board.clear("stepped_down")
        self._rosters.forget_requests()
        self._live.set_cadence(node.config.heartbeat_interval)
        node.handshake_complete = False
        self.handshake.close()
        self._out.events.append(SteppedDown(epoch=node.epoch, to=to))
        node.master = None
        self._epoch_master = to
        self._out.events.append(MasterChanged(master=None, epoch=node.epoch))

    def _follow(self, master: int, epoch: int, now: float) -> None:
        node = self._node
        if node.is_master:
            self._step_down(master, now)
        self._set_epoch(epoch, master)
        node.master = master
        self._live.master_heard(now)
        self._best_claim = None
        self._presumed.clear()
        if self._star:
            # A star member watches its master only; the rest of the swarm it learns from
            # the master's roster (fetched anew: it is the new master's, or newer).
            for peer in [p for p in node.members.peers if p != master]:
                node.members.forget(peer)
            # Until its heartbeats say otherwise, the master beats at the ordinary interval.
            node.members.cadence = node.config.heartbeat_interval
            # On a shared channel the master's heartbeats queue behind the reports its
            # claim sets off (``handshake_airtime``): not given up before they had theirs.
            airtime = self._live.handshake_airtime(self._live.swarm_size() - 1)
            if airtime > 0.0:
                self._live.hold_master(master, now + airtime, now)
            if node.config.channel_bitrate is not None:
                # Heartbeats wait for the report's acknowledgement (``_heartbeats_held``),
                # but not past what an inherited member is held for, nor ``t_leave``.
                self._heartbeats_held_until = now + max(airtime, node.config.t_leave)
            self._live.recount_lowest_peer()  # the master, if in the view: nobody else is
            self._live.forget_probes(keep=master)
        self._out.events.append(MasterChanged(master=master, epoch=epoch))
        node.reliable.retarget(master, now, epoch, MASTER_BOUND)
        self._inbox.follow(master)
        # Always report: requests and claims made while no master was followed were not sent
        # (the report states them), and a resumed master may have dropped us meanwhile.
        self.report(now)

    def lose_master(self, now: float) -> None:
        node = self._node
        if node.master is None:
            return
        lost = node.master
        node.master = None
        self._master_incarnation = -1
        self._listening_since = now
        if self._star:
            # Masterless, it watches whoever broadcasts, at the ordinary interval.
            node.members.cadence = node.config.heartbeat_interval
        if self._star:
            # The master's succession list says who takes over: each successor is presumed
            # alive for a while per rank, so the first live one claims without a round of
            # broadcasts, and the others keep quiet meanwhile. The while covers how much
            # later a successor may notice the loss (its last heartbeats from the master
            # arrived, mine were lost); a successor slower than that claims beside the
            # next one, and the lower of the two keeps the role.
            step = 3 * node.config.heartbeat_interval + node.config.probe_window
            for rank, peer in enumerate(p for p in node.roster.succession if p != lost):
                if peer != node.platform:
                    self._presumed[peer] = now + (rank + 1) * step
        self._out.events.append(MasterChanged(master=None, epoch=node.epoch))
        node.reliable.retarget(None, now)
        self._inbox.follow(None)
        claim = self._best_claim
        if (
            claim is not None
            and claim[0] > node.epoch
            and now - claim[2] <= node.config.t_leave
            and (claim[1] in node.members or self._star)
        ):
            # Someone already claimed while we still trusted the old master: follow at once.
            self._follow(claim[1], claim[0], now)
