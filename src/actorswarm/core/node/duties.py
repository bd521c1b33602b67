"""What a node does as master and what it does as member: two objects with one interface,
:class:`MasterDuties` and :class:`MemberDuties`. The node holds one of them as its role and
swaps it when it claims or steps down (:meth:`Node._take_role
<actorswarm.core.node.coordinator.Node._take_role>`), as raft swaps its step function on
becoming leader, instead of asking ``is_master`` at every step. Neither keeps state of its
own: what outlives a change of role is handed to both at construction — the node's
collector, its master tables (:class:`~.tables.MasterTables`) and, to the master, its
bulletin board — and the handshake is the leadership's (:class:`~.handshake.Handshake`).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Final

from actorswarm.core.barrier import addressee
from actorswarm.core.events import AppReceived, MemberJoined, MemberLeft
from actorswarm.core.node.outbox import ToMember
from actorswarm.core.wire import (
    NORMAL,
    AppMessage,
    BarrierRequest,
    BarrierStale,
    Heartbeat,
    Payload,
    Release,
    ReleaseAck,
    Report,
    RoleClaim,
    RoleDeny,
    RoleGrant,
    RoleRelease,
    RoleRevoke,
    RosterRequest,
    Sync,
)

if TYPE_CHECKING:
    from actorswarm.core.delivery.bulletin import BulletinBoard
    from actorswarm.core.node.coordinator import Node
    from actorswarm.core.node.leadership import Leadership
    from actorswarm.core.node.liveness import Liveness
    from actorswarm.core.node.rostersync import RosterSync
    from actorswarm.core.node.tables import MasterTables
    from actorswarm.core.ready import Collector
    from actorswarm.core.wire import ReleaseRecord

_NO_DEADLINES: Final = (None, None)


class MasterDuties:
    """The master's side: it decides barriers and roles, answers roster requests, posts
    bulletins and runs the handshake's timers."""

    is_master: Final = True

    def __init__(
        self,
        node: Node,
        out: Collector,
        tables: MasterTables,
        board: BulletinBoard,
        *,
        lead: Leadership,
        live: Liveness,
        rosters: RosterSync,
        member: MemberDuties,
    ) -> None:
        self._node = node
        # The parts it calls: who is master (the handshake), who is alive, the roster, and
        # the member's side (its own replies, taken in place).
        self._lead = lead
        self._live = live
        self._rosters = rosters
        self._member = member
        self._star = node.config.membership == "star"  # a star swarm (docs/design.md §3.1)
        self._board = board  # the node's bulletin board (master to every member)
        self._tables = tables  # the master's tables (the node's, kept across roles)
        self._out = out  # the node's collector: what this part sends and reports

    # --- the interface both roles share ---------------------------------------------------

    def reports_awaited(self) -> int:
        return self._lead.handshake.awaited

    def deadlines(self) -> tuple[float | None, float | None]:
        """The barrier table's and the bulletin board's next deadlines."""
        return self._tables.barriers.next_deadline(), self._board.next_deadline()

    def tick(self, now: float) -> None:
        """The handshake's Syncs and deadline, the barrier table's timers, the board's
        retransmissions."""
        node = self._node
        handshake = self._lead.handshake
        for peer in handshake.syncs_due(now):
            sync = Sync(epoch=node.epoch, bulletin=handshake.bulletin)
            node.reliable.send(peer, sync, now, node.epoch)
        if handshake.expired(now):
            self._lead.finish_handshake(now)
        self._tables.barriers.tick(now, node.epoch)
        self.flush(now)
        self._board.tick(now, node.epoch, node.reliable.timeout(None))

    def restate(self, now: float) -> None:
        """A master-bound message was given up: a master has nobody to report to."""

    def to_master(self, payload: Payload, now: float) -> None:
        """Barrier and role traffic of its own is handled in place."""
        self.decide(self._node.platform, payload, now)

    def app_to_master(self, msg: AppMessage, now: float) -> None:
        node = self._node
        self._out.events.append(AppReceived(sender=node.platform, topic=msg.topic, body=msg.body))

    def post_bulletin(self, msg: AppMessage, now: float, skip: tuple[int, ...]) -> None:
        node = self._node
        self._board.post(
            msg,
            set(node.members.peers),
            now,
            node.epoch,
            node.reliable.timeout(None),
            skip=skip,
        )

    def needs_changed(self, now: float, keys: Iterable[int] | None) -> None:
        node = self._node
        self._tables.barriers.needs_changed(now, node.epoch, keys)
        self.flush(now)

    def waiting_occasions(self, key: int) -> tuple[str, ...]:
        return self._tables.barriers.waiting_occasions(key)

    def hold_barrier(self, key: int, until: float) -> None:
        self._tables.barriers.hold(key, until)

    def own_releases(self) -> list[ReleaseRecord]:
        """Firings of an earlier term to report: a master reports to nobody."""
        return []

    def on_roster_request(self, sender: int, body: RosterRequest) -> None:
        node = self._node
        if not (self._star and body.epoch == node.epoch):
            node.counters["drop:roster"] += 1
            return
        self._rosters.asked(sender)

    def on_release_ack(self, sender: int, body: ReleaseAck) -> None:
        node = self._node
        if body.dst != node.platform or body.epoch != node.epoch:
            node.counters["drop:stale_epoch"] += 1
            return
        self._tables.barriers.on_ack(sender, body.key, body.generation)

    def on_master_bound(self, sender: int, epoch: int, payload: Payload, now: float) -> None:
        node = self._node
        if epoch != node.epoch:
            node.counters["drop:stale_epoch"] += 1
            return
        if isinstance(payload, Report) and payload.epoch != node.epoch:
            node.counters["drop:stale_epoch"] += 1
            return
        self.decide(sender, payload, now)

    def on_release(self, sender: int, rel: Release, now: float) -> None:
        """A master takes releases from nobody."""
        self._node.counters["drop:stale_epoch"] += 1

    def member_left(self, change: MemberLeft, now: float) -> None:
        """A member left the view: its requests, roles, bulletins and roster entry go."""
        node = self._node
        self._lead.handshake.left(change.platform, restarted=change.reason == "restarted")
        self._tables.barriers.member_left(change.platform, now, node.epoch)
        self._tables.roles.member_left(change.platform, restarted=change.reason == "restarted")
        self._board.member_left(change.platform)
        self._rosters.log.left(change.platform)

    def member_joined(self, change: MemberJoined, now: float, hb: Heartbeat | None) -> None:
        self._rosters.log.joined(change.platform, change.incarnation)
        self._lead.master_joined(change.platform, now, hb)

    def heartbeat(self, now: float, count: int, suspects: list[int]) -> Heartbeat:
        """The master's heartbeat names the members a barrier of all awaits; a star
        master's also carries the roster's version and changes, the succession list, the
        cadence it asks its members for and its own interval while fast."""
        node = self._node
        awaited = self._tables.barriers.awaited(now, lambda: {*node.members.peers, node.platform})
        if not self._star:
            return Heartbeat(
                is_master=True,
                epoch=node.epoch,
                master=node.master or 0,
                count=count,
                suspects=suspects,
                awaited=awaited,
            )
        log = self._rosters.log
        live = self._live
        return Heartbeat(
            is_master=True,
            epoch=node.epoch,
            master=node.platform,
            count=count,
            suspects=suspects,
            roster=log.version,
            size=len(node.members),
            changes=list(log.changes),
            succession=log.succession(node.members.peers),
            cadence=0.0 if live.cadence == node.config.heartbeat_interval else live.cadence,
            awaited=awaited,
            interval_ms=round(live.own_interval() * 1000) if live.fast else 0,
        )

    def view_changed(self, now: float) -> None:
        """After a change of the view: the handshake may be over, a firing may be due."""
        if self._lead.handshake.settled():
            self._lead.finish_handshake(now)
        self.flush(now)

    # --- the master's own -----------------------------------------------------------------

    def decide(self, sender: int, payload: Payload, now: float) -> None:
        """A master-bound message of ``sender`` (itself included): a barrier request, a
        role claim or release, a report; then what the tables decided goes out."""
        node = self._node
        bm, rm = self._tables.barriers, self._tables.roles
        if isinstance(payload, BarrierRequest):
            bm.request(sender, payload, now, node.epoch)
        elif isinstance(payload, RoleClaim):
            rm.claim(sender, payload)
        elif isinstance(payload, RoleRelease):
            rm.release(sender, payload.role)
        elif isinstance(payload, Report):
            if sender != node.platform and sender not in node.members:
                bm.topology_changed(now)  # a platform from beyond the view: more may follow
            # Releases first: they decide whether a waiting request is to be completed.
            for record in payload.released:
                bm.record_released(sender, record)
            for key, generation in payload.generations.items():
                bm.known_generation(key, generation, now, node.epoch)
            for req in payload.pending:
                bm.request(sender, req, now, node.epoch)
            bm.reported(now, node.epoch)
            rm.report(sender, payload.held, payload.claims)
            if self._lead.handshake.reported(sender):
                self._lead.finish_handshake(now)
        self.flush(now)

    def flush(self, now: float) -> None:
        """Send what the barrier and role tables decided; apply the parts meant for me.

        The tables put what they decide into the node's outbox (:mod:`.outbox`, which says
        why it waits there): it is routed here, to this platform or over a stream, and
        their firings are reported here, after the view changes of the same step that set
        them off."""
        for decision in self._tables.outbox.take():
            if isinstance(decision, Release):
                self._send_release(decision)
            elif isinstance(decision, ToMember):
                self.to_member(decision.platform, decision.payload, now)
            else:
                self._out.events.append(decision)

    def _send_release(self, rel: Release) -> None:
        """Broadcast a release (or send it to its one candidate); pass this platform's own
        entry of it in place."""
        node = self._node
        if any(e.platform == node.platform for e in rel.entries):
            event, _ = node.barriers.on_release(rel)
            if event is not None:
                self._out.events.append(event)
            self._tables.barriers.on_ack(node.platform, rel.key, rel.generation)
            if all(e.platform == node.platform for e in rel.entries):
                return
        self._out.send(addressee(rel, node.platform), rel, NORMAL)

    def to_member(self, platform: int, payload: Payload, now: float) -> None:
        node = self._node
        if platform == node.platform:
            self._member.take(payload, now)
        else:
            node.reliable.send(platform, payload, now, node.epoch)


class MemberDuties:
    """A member's side (also a platform that follows no master): master-bound traffic goes
    to the master it follows, releases and replies come from it."""

    is_master: Final = False

    def __init__(
        self,
        node: Node,
        out: Collector,
        tables: MasterTables,
        *,
        lead: Leadership,
        live: Liveness,
    ) -> None:
        self._node = node
        self._lead = lead  # who is master: a member reports to it
        self._live = live  # who is alive: the watch on its master
        self._tables = tables  # the master's tables (the node's, kept across roles)
        self._out = out  # the node's collector: what this part sends and reports

    def reports_awaited(self) -> int:
        return 0

    def deadlines(self) -> tuple[float | None, float | None]:
        return _NO_DEADLINES

    def tick(self, now: float) -> None:
        """A member's timers are its streams' and its membership's, ticked by the node."""

    def restate(self, now: float) -> None:
        """A master-bound message was given up: report everything again to the master."""
        node = self._node
        if node.master is not None:
            node.counters["restated"] += 1
            self._lead.report(now)

    def to_master(self, payload: Payload, now: float) -> None:
        """Without a master nothing is queued: the report sent on following the next master
        states every pending request and claim."""
        node = self._node
        if node.master is not None:
            node.reliable.send_to_master(payload, now, node.epoch)

    def app_to_master(self, msg: AppMessage, now: float) -> None:
        node = self._node
        node.reliable.send_to_master(msg, now, node.epoch)

    def post_bulletin(self, msg: AppMessage, now: float, skip: tuple[int, ...]) -> None:
        self._node.counters["bulletin_not_master"] += 1

    def needs_changed(self, now: float, keys: Iterable[int] | None) -> None:
        """Only a master decides barriers."""

    def waiting_occasions(self, key: int) -> tuple[str, ...]:
        return ()

    def hold_barrier(self, key: int, until: float) -> None:
        """Only a master decides barriers."""

    def own_releases(self) -> list[ReleaseRecord]:
        """The firings it decided as master in an earlier term (its barrier table is kept
        until it claims again)."""
        node = self._node
        return self._tables.barriers.decided(node.platform)

    def on_roster_request(self, sender: int, body: RosterRequest) -> None:
        self._node.counters["drop:roster"] += 1

    def on_release_ack(self, sender: int, body: ReleaseAck) -> None:
        self._node.counters["drop:stale_epoch"] += 1

    def on_master_bound(self, sender: int, epoch: int, payload: Payload, now: float) -> None:
        self._node.counters["drop:stale_epoch"] += 1

    def on_release(self, sender: int, rel: Release, now: float) -> None:
        node = self._node
        if sender != node.master or rel.epoch != node.epoch:
            node.counters["drop:stale_epoch"] += 1
            return
        event, ack = node.barriers.on_release(rel)
        if event is not None:
            self._out.events.append(event)
        if ack:
            self._out.send(
                sender,
                ReleaseAck(dst=sender, epoch=rel.epoch, key=rel.key, generation=rel.generation),
                NORMAL,
            )

    def member_left(self, change: MemberLeft, now: float) -> None:
        """Only a master keeps tables of its members."""

    def member_joined(self, change: MemberJoined, now: float, hb: Heartbeat | None) -> None:
        """Its master joined the view while a shared channel holds its heartbeats back: the
        hold applies to the new detector too."""
        node = self._node
        if change.platform == node.master:
            self._live.rehold_master(change.platform, now)

    def heartbeat(self, now: float, count: int, suspects: list[int]) -> Heartbeat:
        """A member's heartbeat: whom it follows, in which epoch, whom it suspects."""
        node = self._node
        return Heartbeat(
            is_master=False,
            epoch=node.epoch,
            master=node.master or 0,
            count=count,
            suspects=suspects,
            awaited=[],
        )

    def view_changed(self, now: float) -> None:
        """Only a master has a handshake and firings to flush."""

    # --- the member's own -----------------------------------------------------------------

    def take(self, payload: Payload, now: float) -> None:
        """A message from its master (or, on the master, from itself): a barrier's stale
        notice, a role's grant, denial or revocation."""
        node = self._node
        if isinstance(payload, BarrierStale):
            notice = node.barriers.on_stale(payload)
            if notice is not None:
                self._out.events.append(notice)
        elif isinstance(payload, RoleGrant | RoleDeny | RoleRevoke):
            event = node.roles.on_reply(payload)
            if event is not None:
                self._out.events.append(event)


#: Either role: the interface the node calls without asking which one it holds.
Duties = MasterDuties | MemberDuties
