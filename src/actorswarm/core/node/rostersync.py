"""The roster of a star swarm, for one node (docs/design.md §3.1): a master serves its
roster to the members that ask (or broadcasts it when many do, or when all are behind on a
shared channel); a member keeps its copy current from its master's heartbeats and asks for
the whole roster when it falls behind (see :mod:`actorswarm.core.membership.roster`).
"""

from __future__ import annotations

import random
from typing import TYPE_CHECKING

from actorswarm.core import wire
from actorswarm.core.membership.roster import RosterLog
from actorswarm.core.wire import NORMAL, Heartbeat, RosterChunk, RosterRequest

if TYPE_CHECKING:
    from actorswarm.core.node.coordinator import Node
    from actorswarm.core.node.failures import Failures
    from actorswarm.core.ready import Collector

#: A master that has more members asking for the whole roster than this at one heartbeat
#: broadcasts it once instead of sending it to each.
ROSTER_BROADCAST_FROM = 4


class RosterSync:
    """Serving and following the roster, for one :class:`~actorswarm.core.node.Node`: it
    keeps the master's roster (:attr:`log`) and the requests for it."""

    def __init__(
        self, node: Node, out: Collector, rng: random.Random, *, failures: Failures
    ) -> None:
        self._node = node
        self._failures = failures  # told when the master's roster drops a platform
        self._star = node.config.membership == "star"  # a star swarm (docs/design.md §3.1)
        self._out = out  # the node's collector: what this part sends and reports
        self._rng = rng  # the node's: when a member on a shared channel asks
        # Member: when the roster was last asked for; on a shared channel, a request
        # waiting to go. Master: when the roster was last broadcast.
        self._asked = -1e9
        self._ask_at: float | None = None
        self._broadcast_at = -1e9
        #: Master: the roster (epoch, version) its last heartbeat told.
        self.told = (0, 0)
        #: Master: the roster as it keeps it (its heartbeats carry its version, changes and
        #: succession list).
        self.log = RosterLog(node.config.succession)
        # Master: who asked for the whole roster since the last heartbeat.
        self._requests: set[int] = set()

    def asked(self, member: int) -> None:
        """Master: ``member`` asked for the whole roster (served at the next heartbeat)."""
        self._requests.add(member)

    def forget_requests(self) -> None:
        """Stepping down: the requests were for the master this platform no longer is."""
        self._requests.clear()

    def on_master_heartbeat(self, sender: int, hb: Heartbeat, now: float) -> None:
        """A member's copy of its master's roster after the master's heartbeat: the changes
        it carries applied, and the whole roster asked for when behind."""
        node = self._node
        rejected = node.roster.rejected
        behind = node.roster.on_heartbeat(hb.epoch, hb)
        if node.roster.rejected != rejected:
            node.counters["drop:roster"] += 1
        self._removed(now)
        if not behind:
            self._ask_at = None
        elif self._ask_due(now):
            node.counters["roster_request"] += 1
            self._out.send(
                sender,
                RosterRequest(
                    epoch=hb.epoch,
                    version=node.roster.version if node.roster.epoch == hb.epoch else 0,
                ),
                NORMAL,
            )

    def _outrun(self) -> bool:
        """On a shared channel: the roster changed since the master's last heartbeat by
        more than a heartbeat's changes can tell (a new epoch, a swarm joining by the
        hundred), so every member is behind — one broadcast of the roster serves them all,
        and saves the channel a request from each. Notes the version told."""
        node = self._node
        log = self.log
        told_epoch, told_version = self.told
        self.told = (node.epoch, log.version)
        if node.config.channel_bitrate is None or not node.members:
            return False
        return told_epoch != node.epoch or log.version - told_version > wire.MAX_CHANGES

    def serve_requests(self, now: float) -> None:
        """Send the whole roster to the members that asked since the last heartbeat: to each,
        or once to everyone when many asked (after a failover every member does) or, on a
        shared channel, when all of them are behind (:meth:`_outrun`)."""
        node = self._node
        outrun = self._outrun()
        if not self._requests and not (outrun and now >= self._broadcast_at):
            return
        requesters = sorted(self._requests)
        self._requests.clear()
        members = {p: m.incarnation for p, m in node.members.peers.items()}
        chunks = RosterLog.chunks(node.epoch, self.log.version, members, node.config.roster_chunk)
        if outrun or len(requesters) > ROSTER_BROADCAST_FROM:
            if now < self._broadcast_at:
                # A roster that changes fast (a swarm booting) is broadcast once per t_join
                # at most: the members ask again meanwhile, at no cost to anyone else.
                self._requests.update(requesters)
                return
            self._broadcast_at = now + node.config.t_join
        targets: list[int | None] = (
            [None] if outrun or len(requesters) > ROSTER_BROADCAST_FROM else list(requesters)
        )
        for dst in targets:
            for chunk in chunks:
                self._out.send(dst, chunk, NORMAL)

    def _ask_due(self, now: float) -> bool:
        """A member behind its master's roster asks for it now: at once and at most every
        ``retry_cap`` — or, on a shared channel, where every request takes airtime and a
        master broadcasts the roster by itself when every member is behind (at most once per
        ``t_join``), only when still behind after a random half to one and a half
        ``t_join``, and then at most once per ``t_join``."""
        node = self._node
        cfg = node.config
        if cfg.channel_bitrate is None:
            if now - self._asked < cfg.retry_cap:
                return False
        else:
            if now - self._asked < cfg.t_join:
                return False
            if self._ask_at is None:
                self._ask_at = now + cfg.t_join * self._rng.uniform(0.5, 1.5)
            if now < self._ask_at:
                return False
            self._ask_at = None
        self._asked = now
        return True

    def on_chunk(self, sender: int, chunk: RosterChunk, now: float) -> None:
        """A chunk of the whole roster, taken only from the master this star member
        follows, in its epoch."""
        node = self._node
        if not (
            self._star
            and sender == node.master
            and not node.is_master
            and chunk.epoch == node.epoch
        ):
            node.counters["drop:roster"] += 1
            return
        rejected = node.roster.rejected
        node.roster.on_chunk(chunk)
        if node.roster.rejected != rejected:
            node.counters["drop:roster"] += 1
        self._removed(now)

    def _removed(self, now: float) -> None:
        """Platforms that left the master's view left the swarm for this member too: its
        queues to them are dropped and their messages reported failed."""
        node = self._node
        if not node.roster.removed:
            return
        for platform in node.roster.removed:
            if platform != node.master:
                node.reliable.drop_destination(platform, now)
        node.roster.removed.clear()
        self._failures.report()
