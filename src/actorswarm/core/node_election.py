"""The election layer of a node: claiming, following and stepping down, the loss of the
master and its succession, the handshake (decisions in :mod:`.election`).
"""

from __future__ import annotations

from actorswarm.core.election import OnHeartbeat, should_claim
from actorswarm.core.events import (
    BecameMaster,
    HandshakeComplete,
    MasterChanged,
    SteppedDown,
)
from actorswarm.core.node_base import MASTER_BOUND
from actorswarm.core.node_membership import NodeMembership
from actorswarm.core.roles import RoleMaster
from actorswarm.core.wire import (
    Heartbeat,
    Sync,
)


class NodeElection(NodeMembership):
    """See the module docstring."""

    def _on_sync(self, sender: int, sync: Sync, now: float, incarnation: int = -1) -> None:
        self._max_epoch = max(self._max_epoch, sync.epoch)
        self._sync_bulletins(sender, sync)
        if sender == self.master and sync.epoch == self.epoch:
            self._master_incarnation = max(self._master_incarnation, incarnation)
            self._report(now)
            return
        action = self._decide(sender, True, sync.epoch)
        if not self._apply(action, sender, sync.epoch, now):
            self.counters["drop:stale_epoch"] += 1
        if self.master == sender:
            self._master_incarnation = incarnation
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
            # The firings it decided in an earlier term, which it would have reported to the
            # master it stepped down to: it may claim again before it reported them to anyone
            # (two masters settling after a heal), and a candidate of one whose release was
            # lost could then never be completed (campaign seed 7765517).
            decided = self._bmaster.decided(self.platform)
            self.is_master = True
            self._bmaster = self._new_barrier_master()
            for record in decided:
                self._bmaster.record_released(self.platform, record)
            self._rmaster = RoleMaster()
            if self._star:
                # The predecessor's roster: those platforms were members a moment ago. They
                # are watched from now on and waited for in the handshake, and those that do
                # not answer leave like any silent member — at the cadence they will be
                # asked for, and on a shared channel only once the handshake's packets
                # have had their airtime: their first heartbeats queue behind them.
                inherited = [
                    (p, i)
                    for p, i in self.roster.members.items()
                    if p not in (predecessor, self.platform)
                ]
                self.members.cadence = self._member_cadence(
                    max(len(inherited), self._swarm_size() - 1)
                )
                grace = self._handshake_airtime(len(inherited))
                for peer, incarnation in inherited:
                    self.members.admit(peer, incarnation, now, grace=grace)
                self._lowest_peer = min(self.members.peers, default=None)
        else:  # a new epoch while master: everyone reports again, nothing fires meanwhile
            self._bmaster.ready = False
            self._rmaster.ready = False
            # On a shared channel the members' heartbeats now queue behind their reports
            # (and wait for their acknowledgement) as after any claim.
            hold = now + self._handshake_airtime(len(self.members))
            for peer in list(self.members.peers) if hold > now else ():
                self.members.hold(peer, hold, now)
        self._roster_log.reset(self.epoch)
        self._cadence = self._member_cadence()
        self.members.cadence = self._cadence
        self.handshake_complete = False
        self._bmaster.topology_changed(now)
        self._out.events.append(BecameMaster(epoch=self.epoch))
        self._out.events.append(MasterChanged(master=self.platform, epoch=self.epoch))
        self.reliable.retarget(None, now)
        self._handshake_waiting = set(self.members.peers)
        self._handshake_deadline = now + self.config.handshake_timeout
        # Members follow the claim heartbeat and report on their own; a Sync goes only to
        # those who have not reported after a round trip's worth of retry delay.
        # On a shared channel the reports queue behind each other: no sync before they had
        # their airtime.
        self._sync_at = now + max(
            2 * self.config.retry_base, self._handshake_airtime(len(self._handshake_waiting))
        )
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
            self._out.events.append(HandshakeComplete(epoch=self.epoch, members=len(self.members)))
        self._bmaster.become_ready(now, self.epoch)
        self._rmaster.become_ready()
        self._flush_master(now)

    def _step_down(self, to: int, now: float) -> None:
        self.is_master = False
        self._board.clear("stepped_down")
        self._roster_requests.clear()
        self._cadence = self.config.heartbeat_interval
        self.members.cadence = self._cadence
        self.handshake_complete = False
        self._handshake_waiting.clear()
        self._handshake_deadline = None
        self._sync_at = None
        self._out.events.append(SteppedDown(epoch=self.epoch, to=to))
        self.master = None
        self._epoch_master = to
        self._out.events.append(MasterChanged(master=None, epoch=self.epoch))

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
            # Until its heartbeats say otherwise, the master beats at the ordinary interval.
            self.members.cadence = self.config.heartbeat_interval
            # On a shared channel the master's heartbeats queue behind the reports its
            # claim sets off (``_handshake_airtime``): not given up before they had theirs.
            airtime = self._handshake_airtime(self._swarm_size() - 1)
            if airtime > 0.0:
                self._master_hold = now + airtime
                self.members.hold(master, self._master_hold, now)
            if self.config.channel_bitrate is not None:
                # Heartbeats wait for the report's acknowledgement (``_heartbeats_held``),
                # but not past what an inherited member is held for, nor ``t_leave``.
                self._heartbeats_held_until = now + max(airtime, self.config.t_leave)
            self._lowest_peer = master if master in self.members else None
            self._probe_due = {p: t for p, t in self._probe_due.items() if p == master}
        self._out.events.append(MasterChanged(master=master, epoch=epoch))
        self.reliable.retarget(master, now, epoch, MASTER_BOUND)
        self._inbox.follow(master)
        # Always report: requests and claims made while no master was followed were not sent
        # (the report states them), and a resumed master may have dropped us meanwhile.
        self._report(now)

    def _lose_master(self, now: float) -> None:
        if self.master is None:
            return
        lost = self.master
        self.master = None
        self._master_incarnation = -1
        self._listening_since = now
        if self._star:
            # Masterless, it watches whoever broadcasts, at the ordinary interval.
            self.members.cadence = self.config.heartbeat_interval
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
        self._out.events.append(MasterChanged(master=None, epoch=self.epoch))
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
