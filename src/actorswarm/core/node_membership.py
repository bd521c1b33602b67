"""The membership layer of a node: heartbeats sent and heard, the master's roster, probes of
suspects, local health, and what a change of the view sets off (see :mod:`.membership`,
:mod:`.roster`; on a shared channel, :mod:`.airtime`).
"""

from __future__ import annotations

from actorswarm.core import airtime, wire
from actorswarm.core.election import OnHeartbeat
from actorswarm.core.events import (
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.node_base import (
    MAX_HEALTH,
    NodeBase,
)
from actorswarm.core.ready import PROBE
from actorswarm.core.roster import RosterLog
from actorswarm.core.wire import (
    NORMAL,
    Heartbeat,
    RosterChunk,
    RosterRequest,
)

#: A master that has more members asking for the whole roster than this at one heartbeat
#: broadcasts it once instead of sending it to each.
ROSTER_BROADCAST_FROM = 4


class NodeMembership(NodeBase):
    """See the module docstring."""

    def _heartbeat(self, now: float, *, suspects: list[int] | None = None) -> Heartbeat:
        """This platform's heartbeat; a star master's carries what its members need."""
        if suspects is None:
            suspects = self._suspect_list()
        awaited = (
            self._bmaster.awaited(now, lambda: {*self.members.peers, self.platform})
            if self.is_master
            else []
        )
        if not (self._star and self.is_master):
            return Heartbeat(
                is_master=self.is_master,
                epoch=self.epoch,
                master=self.master or 0,
                count=self._hb_count,
                suspects=suspects,
                awaited=awaited,
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
            awaited=awaited,
            interval_ms=round(self._own_interval() * 1000) if self._fast else 0,
        )

    def _own_interval(self) -> float:
        """How often this platform heartbeats: a star member following a master at the
        cadence its master asks for; a star master at half ``heartbeat_interval`` while it
        is fast (:meth:`_update_fast`); anyone else at ``heartbeat_interval``."""
        if self._following_star():
            return self._cadence
        if self._fast:
            return self.config.heartbeat_interval / 2
        return self.config.heartbeat_interval

    def _update_fast(self) -> None:
        """A star master heartbeats faster while the loss it measures is heavy
        (``fast_master_loss``, with a third of it as hysteresis). Its members watch it
        alone, and the silence that tells a dead master from a run of losses is a number of
        its heartbeats: at twice the rate, half the time. Not on a shared channel, where a
        master's heartbeat (roster, succession) is the largest regular packet on the air."""
        cfg = self.config
        threshold = cfg.fast_master_loss
        if (
            threshold is None
            or cfg.channel_bitrate is not None
            or not (self._star and self.is_master)
        ):
            self._fast = False
            return
        loss = self.members.loss.value
        self._fast = loss >= threshold or (self._fast and loss >= threshold * 2 / 3)

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
        if self._heard is not None:
            self._heard.sweep(now)
        # On a shared channel the roster of a new epoch is broadcast unasked
        # (:meth:`_roster_outrun`), after the claim's heartbeat: a member takes a roster
        # only from the master it follows.
        roster_after = (
            self.config.channel_bitrate is not None and self._roster_told[0] != self.epoch
        )
        self._update_fast()
        if self.is_master and self._star:
            self._cadence = self._member_cadence()
            self.members.cadence = self._cadence
            if not roster_after:
                self._serve_roster_requests(now)
        if self.config.channel_bitrate is not None:
            # What the swarm needs to put one packet each on the shared channel: reliable
            # delivery waits at least that long for an acknowledgement.
            size = self._swarm_size()
            self.reliable.channel_time = airtime.channel_time(self.config, size)
            self.reliable.channel_size = size
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

    def _master_unheard_since(self, now: float) -> bool:
        """The followed master is outside the view and silent for ``t_leave``."""
        return (
            self.master is not None
            and not self.is_master
            and self.master not in self.members
            and now - self._master_heard >= self.members.silence() + self._channel_patience()
            and now >= self._master_hold
        )

    def _check_health(self, now: float) -> None:
        """Local health (Lifeguard): a tick later than asked means this host was not
        listening (a starved CPU, a paused process); each one adds a heartbeat interval of
        grace to every leave decision, and every second of punctual ticks takes one away."""
        late = now - self._due
        if late > self.config.heartbeat_interval / 2:
            if self._health < MAX_HEALTH:
                self._health += 1
                self.counters["late_tick"] += 1
            self._health_decay_at = now + 1.0
        elif self._health and now >= self._health_decay_at:
            self._health -= 1
            self._health_decay_at = now + 1.0

    def _probes(self, suspect: int) -> bool:
        """Whether this platform probes ``suspect``: always — except that on a shared
        channel a star member's silent master is probed by its successors alone. They are
        the ones who act on its loss (the others wait for the claim), and every member of a
        swarm of hundreds probing at once would delay that claim on the air."""
        if self.config.channel_bitrate is None or not self._following_star():
            return True
        return suspect != self.master or self.platform in self.roster.succession

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
            self._emit(peer, self._heartbeat(now, suspects=[peer]), NORMAL, PROBE)
            self._probe_due[peer] = now + self.config.probe_interval

    def _on_heartbeat(
        self, sender: int, incarnation: int, hb: Heartbeat, now: float, seq: int
    ) -> None:
        if sender == wire.GROUND_STATION:
            self.counters["drop:not_for_me"] += 1
            return
        if hb.suspects and self.platform in hb.suspects:
            self._answer_probe(sender, now)
        if hb.awaited and sender == self.master and self.platform in hb.awaited:
            self._hurry(now)
        self._max_epoch = max(self._max_epoch, hb.epoch)
        if sender == self.master and not self.is_master:
            if incarnation > self._master_incarnation >= 0:
                # My master rebooted: the new incarnation claims nothing (a heartbeat of an
                # older epoch would otherwise pass for a late one from before its claim).
                self.counters["master_restarted"] += 1
                self._lose_master(now)
            elif hb.is_master:
                self._master_incarnation = incarnation
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
        action = self._decide(sender, hb.is_master, hb.epoch)
        if action is OnHeartbeat.IGNORE:
            better = self._best_claim is None or hb.epoch > self._best_claim[0]
            if hb.is_master and hb.epoch > self.epoch and better:
                self._best_claim = (hb.epoch, sender, now)
            return
        if self._apply(action, sender, hb.epoch, now):
            if action is OnHeartbeat.FOLLOW and self.master == sender:
                # Known from its first heartbeat, so that its reboot is noticed even if it
                # is the last one heard (campaign seed 951123, broadcast).
                self._master_incarnation = incarnation
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
        # The one peer this member watches heartbeats at this interval: its silence is
        # judged in those heartbeats (loss-aware leave time, suspicion).
        self.members.cadence = hb.interval_ms / 1000 or self.config.heartbeat_interval
        cadence = hb.cadence if hb.cadence > 0 else self.config.heartbeat_interval
        if cadence != self._cadence:
            # Every member hears a master's first slow cadence in the same heartbeat: each
            # takes a phase of its own for it within one interval, or they would all
            # heartbeat in the same instant on a shared channel. Later changes keep the
            # schedule (a new phase at each would put the next heartbeat off again and
            # again while the master's count grows), bringing it forward when faster.
            if self._cadence == self.config.heartbeat_interval:
                self._next_heartbeat = now + self._rng.uniform(0, cadence)
            else:
                self._next_heartbeat = min(self._next_heartbeat, now + cadence)
            self._cadence = cadence
        rejected = self.roster.rejected
        behind = self.roster.on_heartbeat(hb.epoch, hb)
        if self.roster.rejected != rejected:
            self.counters["drop:roster"] += 1
        self._roster_removed(now)
        if not behind:
            self._roster_ask_at = None
        elif self._roster_ask_due(now):
            self.counters["roster_request"] += 1
            self._emit(
                sender,
                RosterRequest(
                    epoch=hb.epoch,
                    version=self.roster.version if self.roster.epoch == hb.epoch else 0,
                ),
                NORMAL,
            )

    def _roster_ask_due(self, now: float) -> bool:
        """A member behind its master's roster asks for it now: at once and at most every
        ``retry_cap`` — or, on a shared channel, where every request takes airtime and a
        master broadcasts the roster by itself when every member is behind (at most once per
        ``t_join``), only when still behind after a random half to one and a half
        ``t_join``, and then at most once per ``t_join``."""
        cfg = self.config
        if cfg.channel_bitrate is None:
            if now - self._roster_asked < cfg.retry_cap:
                return False
        else:
            if now - self._roster_asked < cfg.t_join:
                return False
            if self._roster_ask_at is None:
                self._roster_ask_at = now + cfg.t_join * self._rng.uniform(0.5, 1.5)
            if now < self._roster_ask_at:
                return False
            self._roster_ask_at = None
        self._roster_asked = now
        return True

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

    def _hurry(self, now: float) -> None:
        """My master names me as awaited by a barrier of all: what it has not acknowledged
        of mine goes again now, at most once per two heartbeat intervals (so a request
        still queued on a busy channel is not sent on every heartbeat)."""
        sent = self.reliable.hurry_master(now, 2 * self.config.heartbeat_interval)
        if sent:
            self.counters["hurried"] += sent

    def _answer_probe(self, prober: int, now: float) -> None:
        """A peer suspects me: answer it directly (at most twice per probe interval)."""
        if now - self._answered.get(prober, -1e9) < self.config.probe_interval / 2:
            return
        if len(self._answered) > 4 * wire.MAX_SUSPECTS:
            horizon = now - self.config.probe_interval
            self._answered = {p: t for p, t in self._answered.items() if t >= horizon}
        self._answered[prober] = now
        self.counters["probe_answered"] += 1
        self._emit(prober, self._heartbeat(now), NORMAL, PROBE)

    def _membership_changed(
        self, changes: list[MemberJoined | MemberLeft], now: float, hb: Heartbeat | None = None
    ) -> None:
        if not changes:
            return
        for change in changes:
            self._out.events.append(change)
            if isinstance(change, MemberLeft):
                self.reliable.drop_destination(change.platform, now)
                self._probe_due.pop(change.platform, None)
                if change.reason == "restarted":
                    self.reliable.forget_sender(change.platform, change.incarnation)
                if self.is_master:
                    self._handshake_waiting.discard(change.platform)
                    self._bmaster.member_left(change.platform, now, self.epoch)
                    self._rmaster.member_left(
                        change.platform, restarted=change.reason == "restarted"
                    )
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
            elif change.platform == self.master and self._master_hold > now:
                self.members.hold(change.platform, self._master_hold, now)
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
