"""Who is alive, as one node sees it: heartbeats sent (when, to whom, paced to the master
on a daemon) and heard, probes of suspects, local health, the swarm-size estimate, and
what a change of the view sets off (see :mod:`actorswarm.core.membership.view`; on a shared
channel, :mod:`actorswarm.core.membership.airtime`).
"""

from __future__ import annotations

import math
import random
from typing import TYPE_CHECKING

from actorswarm.core import wire
from actorswarm.core.election import OnHeartbeat
from actorswarm.core.events import (
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.membership import airtime
from actorswarm.core.ready import PROBE, Collector
from actorswarm.core.wire import (
    NORMAL,
    Heartbeat,
)

if TYPE_CHECKING:
    from actorswarm.core.node.coordinator import Node
    from actorswarm.core.node.failures import Failures
    from actorswarm.core.node.rostersync import RosterSync

#: Local health (Lifeguard): at most this many heartbeat intervals of grace for a host that
#: ticks late.
MAX_HEALTH = 8


class Liveness:
    """Who is alive, for one :class:`~actorswarm.core.node.Node`: see the module docstring.
    It acts on the node's shared state (view, master, epoch) and keeps its own: the
    heartbeat schedule and count, the member cadence, the probes and their answers, the
    lowest peer, the watch on the followed master, and local health. The node asks it
    (:attr:`next_heartbeat`, :meth:`next_probe`, :meth:`master_deadline`, :attr:`grace`)
    rather than reading that state."""

    def __init__(
        self,
        node: Node,
        out: Collector,
        now: float,
        rng: random.Random,
        heard: airtime.HeardLog | None,
        *,
        rosters: RosterSync,
        failures: Failures,
    ) -> None:
        self._node = node
        self._failures = failures  # told after a view change: messages to those who left
        self._rosters = rosters  # the star roster: served with a master's heartbeats
        self._star = node.config.membership == "star"  # a star swarm (docs/design.md §3.1)
        self._out = out  # the node's collector: what this part sends and reports
        self._rng = rng  # the node's: the phase of its heartbeats
        # The node's log of every platform heard lately (on a shared channel; else None).
        self._heard = heard
        interval = node.config.heartbeat_interval
        if self._star:
            # Lower IDs speak first at boot (up to one interval later for the highest ID), so
            # a booting swarm hears its lowest IDs before the others would broadcast, and
            # they keep quiet. The phase is drawn afresh after this first heartbeat.
            self._next_heartbeat = now + interval * (
                math.log2(node.platform) / 16 + rng.uniform(0.0, 0.05)
            )
        else:
            self._next_heartbeat = now + rng.uniform(0.0, interval)
        # After the boot heartbeat, draw a phase of its own (star: the boot heartbeat's
        # phase follows the platform's rank).
        self._rephase = self._star
        # Suspicion: when each suspect is probed next.
        self._probe_due: dict[int, float] = {}
        # The lowest ID of the view (None: nobody else), kept up to date per change.
        self._lowest_peer: int | None = None
        # When the host was asked to tick next (local health, :meth:`check_health`).
        self._due = now
        # When the followed master was last heard: a master followed before it joined the
        # view (or that left it and came back) has no leave detector of its own yet.
        self._master_heard = now
        # A star member on a shared channel does not give up its new master before this:
        # the master's heartbeats queue behind the packets its claim set off.
        self._master_hold = -math.inf
        # The member heartbeat interval: the one a star master asks for (its own members'),
        # or its master asked for (a star member's own), else ``heartbeat_interval``.
        self._cadence = node.config.heartbeat_interval
        #: Heartbeats sent so far (scheduled ones; probes and probe answers not counted).
        self.hb_count = 0
        #: As a star master: heartbeating twice per interval under heavy loss
        #: (``CoreConfig.fast_master_loss``, :meth:`_update_fast`).
        self.fast = False
        # Star: lower IDs heard lately without a master (:meth:`lower_heard`).
        self._heard_lower: dict[int, float] = {}
        # When each prober was last answered.
        self._answered: dict[int, float] = {}
        # Local health: how late the host ticks, as a grace on every leave decision.
        self.health = 0
        self._health_decay_at = now
        self._changes: list[MemberJoined | MemberLeft] = []  # scratch, reused per heartbeat

    @property
    def next_heartbeat(self) -> float:
        """When the next scheduled heartbeat is due."""
        return self._next_heartbeat

    def heartbeat_due(self, now: float) -> bool:
        """Whether a host awake at ``now`` sends the scheduled heartbeat (within
        :meth:`heartbeat_window` of its time)."""
        return now + self.heartbeat_window() >= self._next_heartbeat

    def next_probe(self) -> float | None:
        """When the next suspect is probed (None: no suspect)."""
        return min(self._probe_due.values(), default=None)

    def expect_tick(self, at: float) -> None:
        """The host was asked to tick by ``at``: a tick much later tells a host that was
        not listening (:meth:`check_health`)."""
        self._due = at

    def suspected(self, peers: list[int], now: float) -> None:
        """``peers`` became suspects at ``now``: each one this platform :meth:`probes` is
        probed at the next :meth:`probe`."""
        node = self._node
        for peer in peers:
            node.counters["suspected"] += 1
            if self.probes(peer):
                self._probe_due[peer] = now

    def forget_probes(self, keep: int | None = None) -> None:
        """Probe nobody (a new master's members are watched afresh) but ``keep`` (a star
        member watches its master alone)."""
        self._probe_due = {p: t for p, t in self._probe_due.items() if p == keep}

    def following_star(self) -> bool:
        """A star member that follows a live remote master (heartbeats to it only)."""
        node = self._node
        return self._star and node.master is not None and not node.is_master

    @property
    def grace(self) -> float:
        """Extra patience of every leave decision: while this host ticks late (local
        health), and for a star member on a shared channel (:meth:`channel_patience`)."""
        return self.health * self._node.config.heartbeat_interval + self.channel_patience()

    def channel_patience(self) -> float:
        """On a shared channel, how much longer a star member waits for its master's
        heartbeats: twice the time the swarm takes to put a packet each on the air (0
        otherwise). They queue behind the swarm's bursts — a barrier of all puts a request,
        its acknowledgement and a release acknowledgement of every member on the air at
        once — and a member that gives its master up for that starts a needless failover."""
        return 2 * self._node.reliable.channel_time if self.following_star() else 0.0

    @property
    def cadence(self) -> float:
        """The member heartbeat interval: as a star master, the one it asks its members for;
        as a star member, the one its master asked for; else ``heartbeat_interval``."""
        return self._cadence

    def set_cadence(self, cadence: float) -> None:
        """This platform's members heartbeat at ``cadence`` (a master's own, or the ordinary
        interval after stepping down): ask for it and judge their silence by it."""
        self._cadence = cadence
        self._node.members.cadence = cadence

    def master_heard(self, now: float) -> None:
        """The followed master (just followed, or heard) was heard at ``now``."""
        self._master_heard = now

    def hold_master(self, master: int, until: float, now: float) -> None:
        """On a shared channel: the master just followed is not given up before ``until``
        (its heartbeats queue behind the reports its claim sets off)."""
        self._master_hold = until
        self._node.members.hold(master, until, now)

    def rehold_master(self, master: int, now: float) -> None:
        """The followed master joined the view while a shared channel holds its heartbeats
        back: the hold applies to the new detector too."""
        if self._master_hold > now:
            self._node.members.hold(master, self._master_hold, now)

    def master_deadline(self) -> float | None:
        """By when a followed master outside the view must be heard again, or is lost
        (:meth:`master_unheard_since`); None when there is no such master."""
        node = self._node
        if node.master is None or node.is_master or node.master in node.members:
            return None
        silent_until = self._master_heard + node.members.silence() + self.channel_patience()
        return max(silent_until, self._master_hold)

    @property
    def lowest_peer(self) -> int | None:
        """The lowest ID in the view but this platform's (None: the view is empty)."""
        return self._lowest_peer

    def recount_lowest_peer(self) -> None:
        """The view was changed wholesale (not by joins and leaves): find its lowest ID
        again."""
        self._lowest_peer = min(self._node.members.peers, default=None)

    def _heartbeat(self, now: float, *, suspects: list[int] | None = None) -> Heartbeat:
        """This platform's heartbeat (its role's: a star master's carries what its members
        need), naming ``suspects`` (default: its suspects, rotating through many)."""
        node = self._node
        if suspects is None:
            suspects = self._suspect_list()
        return node._role.heartbeat(now, self.hb_count, suspects)

    def member_cadence(self, members: int | None = None) -> float:
        """The member heartbeat interval a star master asks for
        (:func:`~actorswarm.core.membership.airtime.member_cadence`) for ``members`` (default: every
        other platform of :meth:`swarm_size`)."""
        node = self._node
        if not self._star:
            return node.config.heartbeat_interval
        others = self.swarm_size() - 1 if members is None else members
        return airtime.member_cadence(node.config, others)

    def swarm_size(self) -> int:
        """This platform's estimate of the swarm's size, itself included: the largest of its
        view, its copy of the roster, the platforms it heard lately (on a shared channel) and,
        for a star member, the size its master's cadence implies. Before a master has heard
        its members, or a member has the roster, the platforms heard are what is known —
        at boot every platform broadcasts a heartbeat once — and a boot paced by the view
        alone would start a swarm of hundreds at 10 Hz on a channel that carries a tenth."""
        node = self._node
        size = max(len(node.members), len(node.roster.members), len(self._heard or ()))
        if not node.is_master:  # a master's own cadence follows from this: it must not feed it
            size = max(size, airtime.implied_size(node.config, self._cadence))
        return size + 1

    def handshake_airtime(self, members: int) -> float:
        """:func:`~actorswarm.core.membership.airtime.handshake_airtime` of this platform's
        channel."""
        node = self._node
        return airtime.handshake_airtime(node.config, members)

    def _rides_master(self) -> bool:
        """Whether this platform's heartbeats ride on its master's: a star member following
        a live master, with a heartbeat slack (a daemon)."""
        node = self._node
        return bool(node.config.heartbeat_slack) and self.following_star()

    def heartbeat_window(self) -> float:
        """How long before its time a heartbeat goes out on a wake the host makes anyway:
        the slack; or, for one that rides on its master's, two slacks before the time it
        goes out on a wake of its own, a window a slack either side of its phase: the
        master's heartbeats come up to a slack early (a busy master sends early on a wake
        it makes anyway) or late (a loaded host, a radio's jitter), and a window of one
        slack before lost them at every early one, waking twice per interval until the
        phase drifted back (see :meth:`heartbeat_tick`)."""
        node = self._node
        slack = node.config.heartbeat_slack or 0.0
        return 2 * slack if self._rides_master() else slack

    def heartbeat_tick(self, now: float) -> None:
        """Send the scheduled heartbeat if it is due (within :meth:`heartbeat_window`), and
        schedule the next one."""
        node = self._node
        if now + self.heartbeat_window() >= self._next_heartbeat:
            self.send_heartbeat(now)
            interval = self.own_interval()
            if self._rephase:  # after the boot heartbeat: a phase of its own, not its rank's
                self._rephase = False
                interval *= self._rng.uniform(0.5, 1.5)
            if self._rides_master() and now >= self._next_heartbeat:
                # A wake of its own: nothing it could ride on came within a slack of its
                # time. Half a slack later next time, towards the wakes its master's
                # heartbeats cause, until they come within the window; then it keeps that
                # phase (below), so the rate stays one per cadence however often it wakes.
                self._next_heartbeat += interval + (node.config.heartbeat_slack or 0.0) / 2
            else:
                # Sent early, on a tick the host made anyway: keep the phase, so the rate
                # stays one per interval.
                self._next_heartbeat += interval
            if self._next_heartbeat <= now:  # the host fell behind: do not burst
                self._next_heartbeat = now + interval

    def own_interval(self) -> float:
        """How often this platform heartbeats: a star member following a master at the
        cadence its master asks for; a star master at half ``heartbeat_interval`` while it
        is fast (:meth:`_update_fast`); anyone else at ``heartbeat_interval``."""
        node = self._node
        if self.following_star():
            return self._cadence
        if self.fast:
            return node.config.heartbeat_interval / 2
        return node.config.heartbeat_interval

    def _update_fast(self) -> None:
        """A star master heartbeats faster while the loss it measures is heavy
        (``fast_master_loss``, with a third of it as hysteresis). Its members watch it
        alone, and the silence that tells a dead master from a run of losses is a number of
        its heartbeats: at twice the rate, half the time. Not on a shared channel, where a
        master's heartbeat (roster, succession) is the largest regular packet on the air."""
        node = self._node
        cfg = node.config
        threshold = cfg.fast_master_loss
        if (
            threshold is None
            or cfg.channel_bitrate is not None
            or not (self._star and node.is_master)
        ):
            self.fast = False
            return
        loss = node.members.loss.value
        self.fast = loss >= threshold or (self.fast and loss >= threshold * 2 / 3)

    def _suspect_list(self) -> list[int]:
        """Up to MAX_SUSPECTS suspects, rotating through them when there are more."""
        node = self._node
        suspects = node.members.suspects
        if not suspects:
            return []
        ordered = sorted(suspects)
        if len(ordered) <= wire.MAX_SUSPECTS:
            return ordered
        start = (self.hb_count * wire.MAX_SUSPECTS) % len(ordered)
        return (ordered[start:] + ordered[:start])[: wire.MAX_SUSPECTS]

    def send_heartbeat(self, now: float) -> None:
        """The scheduled heartbeat: to the master alone when following one in a star, else
        broadcast — except that a masterless star platform that hears a lower ID (or presumes
        a lower successor alive) keeps quiet: it could not become master, and at boot this is
        what keeps a thousand platforms from all broadcasting at once."""
        node = self._node
        self.hb_count += 1
        if self._heard is not None:
            self._heard.sweep(now)
        # On a shared channel the roster of a new epoch is broadcast unasked
        # (:meth:`.RosterSync._outrun`), after the claim's heartbeat: a member takes a roster
        # only from the master it follows.
        roster_after = (
            node.config.channel_bitrate is not None and self._rosters.told[0] != node.epoch
        )
        self._update_fast()
        if node.is_master and self._star:
            self.set_cadence(self.member_cadence())
            if not roster_after:
                self._rosters.serve_requests(now)
        if node.config.channel_bitrate is not None:
            # What the swarm needs to put one packet each on the shared channel: reliable
            # delivery waits at least that long for an acknowledgement.
            size = self.swarm_size()
            node.reliable.channel_time = airtime.channel_time(node.config, size)
            node.reliable.channel_size = size
        hb = self._heartbeat(now)
        if self.following_star():
            if self._heartbeats_held(now):
                node.counters["heartbeat_held"] += 1
            else:
                self._out.send(node.master, hb, NORMAL)
        elif self._quiet(now) and not (self.hb_count == 1 and self._heard is not None):
            # On a shared channel the first heartbeat goes out all the same: one packet per
            # platform, and every platform hears how many there are (:meth:`swarm_size`)
            # before the first claim asks all of them to report at once.
            node.counters["heartbeat_quiet"] += 1
        else:
            self._out.send(None, hb, NORMAL)
        if roster_after and node.is_master and self._star:
            self._rosters.serve_requests(now)

    def _heartbeats_held(self, now: float) -> bool:
        """On a shared channel, a star member heartbeats to a master it just followed only
        once its report is acknowledged: a claim at boot sets off a report from every
        platform before the master knows how many there are and can ask for a cadence, and
        members heartbeating at 10 Hz meanwhile would fill the channel its heartbeats need
        (docs/collective-core.md, "Airtime"). By then the master has counted the reports it
        received, and its heartbeat carries a cadence for them."""
        node = self._node
        return node._lead.holds_heartbeats(now)

    def _quiet(self, now: float) -> bool:
        node = self._node
        if not self._star or node.is_master or node.master is not None:
            return False
        if node._lead.presumes_lower():
            return True
        return bool(self.lower_heard(now))

    def lower_heard(self, now: float) -> list[int]:
        """Lower IDs heard lately without a master (they elect, so I need not be heard).

        A lower ID that is a master does not count: if I do not follow it (its epoch is
        below mine), it must hear me to claim again above my epoch. "Lately" is as long as
        a member stays in a view, so a lost heartbeat or two change nothing."""
        node = self._node
        horizon = now - max(node.config.t_join, node.members.silence())
        heard = self._heard_lower
        for peer in [p for p, t in heard.items() if t < horizon]:
            del heard[peer]
        return list(heard)

    def master_unheard_since(self, now: float) -> bool:
        """The followed master is outside the view and silent for ``t_leave``."""
        node = self._node
        return (
            node.master is not None
            and not node.is_master
            and node.master not in node.members
            and now - self._master_heard >= node.members.silence() + self.channel_patience()
            and now >= self._master_hold
        )

    def check_health(self, now: float) -> None:
        """Local health (Lifeguard): a tick later than asked means this host was not
        listening (a starved CPU, a paused process); each one adds a heartbeat interval of
        grace to every leave decision, and every second of punctual ticks takes one away."""
        node = self._node
        late = now - self._due
        if late > node.config.heartbeat_interval / 2:
            if self.health < MAX_HEALTH:
                self.health += 1
                node.counters["late_tick"] += 1
            self._health_decay_at = now + 1.0
        elif self.health and now >= self._health_decay_at:
            self.health -= 1
            self._health_decay_at = now + 1.0

    def probes(self, suspect: int) -> bool:
        """Whether this platform probes ``suspect``: always — except that on a shared
        channel a star member's silent master is probed by its successors alone. They are
        the ones who act on its loss (the others wait for the claim), and every member of a
        swarm of hundreds probing at once would delay that claim on the air."""
        node = self._node
        if node.config.channel_bitrate is None or not self.following_star():
            return True
        return suspect != node.master or node.platform in node.roster.succession

    def probe(self, now: float) -> None:
        """Probe the suspects directly (a heartbeat naming them, sent to each): at once on
        suspicion, then every ``probe_interval`` while there are few; many suspects at once
        (a master after a mass failure) are probed by the list in the heartbeats alone."""
        node = self._node
        if not self._probe_due:
            return
        suspects = node.members.suspects
        for peer in [p for p in self._probe_due if p not in suspects]:
            del self._probe_due[peer]
        if len(self._probe_due) > wire.MAX_SUSPECTS // 4:
            due = [p for p, t in self._probe_due.items() if t == now]  # fresh suspicions only
            for peer in self._probe_due:
                self._probe_due[peer] = now + node.config.heartbeat_interval
        else:
            due = [p for p, t in self._probe_due.items() if t <= now]
        for peer in due:
            node.counters["probe"] += 1
            self._out.send(peer, self._heartbeat(now, suspects=[peer]), NORMAL, PROBE)
            self._probe_due[peer] = now + node.config.probe_interval

    def on_heartbeat(
        self, sender: int, incarnation: int, hb: Heartbeat, now: float, seq: int
    ) -> None:
        node = self._node
        if sender == wire.GROUND_STATION:
            node.counters["drop:not_for_me"] += 1
            return
        if hb.suspects and node.platform in hb.suspects:
            self._answer_probe(sender, now)
        if hb.awaited and sender == node.master and node.platform in hb.awaited:
            self._hurry(now)
        node._lead.saw_epoch(hb.epoch)
        if sender == node.master and not node.is_master:
            node._lead.master_incarnation_heard(incarnation, hb.is_master, now)
        if sender < node.platform and self._star and node.master is None:
            # Only a lower ID that follows no master either keeps this one quiet: one that
            # follows a master this platform does not (its probe answers reach me) or is a
            # master itself cannot stand in for me in an election.
            if hb.is_master or hb.master:
                self._heard_lower.pop(sender, None)
            else:
                self._heard_lower[sender] = now
        # A star member that follows a master watches that master only: other platforms'
        # heartbeats matter to it for the election alone (a master, or its own master's).
        if not self.following_star() or sender == node.master:
            changes = self._changes  # reused: this runs for every heartbeat heard
            node.members.heartbeat(sender, incarnation, now, changes, seq, hb.count)
            if changes:
                self._changes = []
                self.membership_changed(changes, now, hb)
        if sender == node.master:
            self._master_heard = now
            if hb.is_master and hb.epoch == node.epoch and not node.is_master:
                self._on_master_heartbeat(sender, hb, now)
        if not (hb.is_master or node.is_master or sender == node._lead.epoch_master):
            return  # the common case at scale: an ordinary member's heartbeat
        action = node._lead.decide(sender, hb.is_master, hb.epoch, hb.master)
        if action is OnHeartbeat.IGNORE:
            node._lead.heard_claim(sender, hb.is_master, hb.epoch, now)
            return
        if node._lead.apply(action, sender, hb.epoch, now):
            if action is OnHeartbeat.FOLLOW and node.master == sender:
                # Known from its first heartbeat, so that its reboot is noticed even if it
                # is the last one heard (campaign seed 951123, broadcast).
                node._lead.followed_in(incarnation)
                self._on_master_heartbeat(sender, hb, now)
            return
        if action is OnHeartbeat.DEMOTED:  # my master gave up; follow whom it follows, if any
            node._lead.demoted(sender, hb.master, now)

    def _on_master_heartbeat(self, sender: int, hb: Heartbeat, now: float) -> None:
        """What a member takes from its master's heartbeat: the cadence it asks for, the
        succession list, and the roster (asking for all of it when behind)."""
        node = self._node
        if not self._star:
            return
        # The one peer this member watches heartbeats at this interval: its silence is
        # judged in those heartbeats (loss-aware leave time, suspicion).
        node.members.cadence = hb.interval_ms / 1000 or node.config.heartbeat_interval
        cadence = hb.cadence if hb.cadence > 0 else node.config.heartbeat_interval
        if cadence != self._cadence:
            # Every member hears a master's first slow cadence in the same heartbeat: each
            # takes a phase of its own for it within one interval, or they would all
            # heartbeat in the same instant on a shared channel. Later changes keep the
            # schedule (a new phase at each would put the next heartbeat off again and
            # again while the master's count grows), bringing it forward when faster.
            if self._cadence == node.config.heartbeat_interval:
                self._next_heartbeat = now + self._rng.uniform(0, cadence)
            else:
                self._next_heartbeat = min(self._next_heartbeat, now + cadence)
            self._cadence = cadence
        self._rosters.on_master_heartbeat(sender, hb, now)

    def _hurry(self, now: float) -> None:
        """My master names me as awaited by a barrier of all: what it has not acknowledged
        of mine goes again now, at most once per two heartbeat intervals (so a request
        still queued on a busy channel is not sent on every heartbeat)."""
        node = self._node
        sent = node.reliable.hurry_master(now, 2 * node.config.heartbeat_interval)
        if sent:
            node.counters["hurried"] += sent

    def _answer_probe(self, prober: int, now: float) -> None:
        """A peer suspects me: answer it directly (at most twice per probe interval)."""
        node = self._node
        if now - self._answered.get(prober, -1e9) < node.config.probe_interval / 2:
            return
        if len(self._answered) > 4 * wire.MAX_SUSPECTS:
            horizon = now - node.config.probe_interval
            self._answered = {p: t for p, t in self._answered.items() if t >= horizon}
        self._answered[prober] = now
        node.counters["probe_answered"] += 1
        self._out.send(prober, self._heartbeat(now), NORMAL, PROBE)

    def membership_changed(
        self, changes: list[MemberJoined | MemberLeft], now: float, hb: Heartbeat | None = None
    ) -> None:
        node = self._node
        if not changes:
            return
        for change in changes:
            self._out.events.append(change)
            if isinstance(change, MemberLeft):
                node.reliable.drop_destination(change.platform, now)
                self._probe_due.pop(change.platform, None)
                if change.reason == "restarted":
                    node.reliable.forget_sender(change.platform, change.incarnation)
                node._role.member_left(change, now)
                if change.platform == node.master:
                    node._lead.lose_master(now)
            else:
                node._role.member_joined(change, now, hb)
        self._update_lowest_peer(changes)
        self._failures.report()
        node._role.view_changed(now)
        node._lead.maybe_claim(now)

    def _update_lowest_peer(self, changes: list[MemberJoined | MemberLeft]) -> None:
        """Keep the lowest ID of the view in O(1) per join; only losing the lowest one costs
        a scan (at boot a platform sees N joins: a scan per join would be O(N²))."""
        node = self._node
        lowest = self._lowest_peer
        for change in changes:
            if isinstance(change, MemberJoined):
                if lowest is None or change.platform < lowest:
                    lowest = change.platform
            elif change.platform == lowest:
                lowest = None if not node.members.peers else -1
        if lowest == -1:
            lowest = min(node.members.peers)
        self._lowest_peer = lowest
