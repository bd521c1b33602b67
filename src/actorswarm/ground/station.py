"""The ground station's protocol endpoint, sans-IO like the core.

Theory of operation
-------------------
The ground station is platform 0. It is not a member of the swarm (it sends no heartbeats
and is never elected); it learns who is out there from the platforms' heartbeats — in a star
swarm, where members heartbeat to their master only, from the master's roster, which it
fetches like a member that is behind — and talks
to each platform over the core's reliable streams on the *urgent* channel, so its commands
are retransmitted until acknowledged and processed before swarm traffic. A host drives it
like a :class:`~actorswarm.core.Node`: every packet comes in through the host's
:class:`~actorswarm.security.pipeline.Pipeline` (checked by its guard, then
``receive_packet``), ``tick`` at ``next_deadline``, and its output leaves through
:meth:`GroundStation.ready` — packets only (it reports no events: its replies are kept
here). Its output goes through a core :class:`~actorswarm.core.ready.Collector`; unlike a
node's, its streams' packets are numbered when taken, after the ones it made directly.

``deploy`` sends a script in chunks to the expected platforms and records which ones confirm
its SHA-256; ``start`` is refused (:class:`NotConfirmed`, naming the missing platforms) until
all of them have, unless forced. Every reply is kept in :attr:`GroundStation.replies`.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from dataclasses import dataclass

from actorswarm.core import wire
from actorswarm.core.config import CoreConfig
from actorswarm.core.delivery.reliable import Reliable
from actorswarm.core.membership.roster import RosterView
from actorswarm.core.ready import Collector, Ready
from actorswarm.core.wire import (
    URGENT,
    Ack,
    AppMessage,
    Data,
    Heartbeat,
    Packet,
    RosterChunk,
    RosterRequest,
)
from actorswarm.engine import commands as cmds


class NotConfirmed(RuntimeError):
    """``start`` before every expected platform confirmed the script."""

    def __init__(self, sha256: str, missing: list[int]) -> None:
        super().__init__(
            f"script {sha256[:12]} not confirmed by platforms {missing}; "
            "wait for them, or force the start"
        )
        self.missing = missing


@dataclass(frozen=True, slots=True)
class ReplyRecord:
    t: float
    platform: int
    reply: cmds.Reply


class GroundStation:
    """The operator's endpoint for swarm ``swarm``."""

    def __init__(
        self,
        *,
        swarm: str,
        now: float = 0.0,
        incarnation: int = 0,
        config: CoreConfig | None = None,
    ):
        self.swarm = swarm
        self.incarnation = incarnation
        self.config = config or CoreConfig()
        # Its own packets are numbered as they are made, its streams' when drained.
        self._out = Collector(swarm=swarm, sender=wire.GROUND_STATION, incarnation=incarnation)
        self.reliable = Reliable(self.config, self._out)
        self._occasions = 0
        #: When each platform was last heard, and its (incarnation, master?, epoch).
        self.heard: dict[int, float] = {}
        #: Platforms any packet of which reached this ground station (the others of
        #: :attr:`heard` are known from a star master's roster only: :attr:`listed`).
        self.direct: set[int] = set()
        self.state: dict[int, tuple[int, bool, int]] = {}
        self.confirmed: dict[str, set[int]] = {}
        #: By script: when its task began (UTC seconds), as the platforms already running
        #: it said when they confirmed it; a start gives it to the others.
        self.began: dict[str, float] = {}
        self.expected: dict[str, set[int]] = {}
        self.replies: list[ReplyRecord] = []
        #: Platforms a command was given up on (no acknowledgement by ``delivery_deadline``),
        #: with when: a command's outcome for them is "unreachable", not "no answer yet".
        self.unreachable: dict[int, float] = {}
        #: Platforms that acknowledged or sent this session anything of its reliable
        #: streams, with when: they accept its packets. A platform heard but absent here
        #: refuses them (or the link to it is one-way): see :mod:`actorswarm.ground.silence`.
        self.acked: dict[int, float] = {}
        self.counters: dict[str, int] = {}
        self.deployed_sha = ""
        # A star master's roster: the members the ground station does not hear directly.
        self.roster = RosterView()
        self._roster_master: int | None = None
        self._roster_asked = -1e9
        #: When an acknowledgement to another ground-station session was last heard (the
        #: swarm's acknowledgements to platform 0 reach every session listening): another
        #: operator is at work.
        self.other_session_heard = -1e9

    # --- operator interface ------------------------------------------------------------

    def send(self, command: cmds.Command, platforms: Iterable[int], now: float) -> None:
        body = cmds.encode(command)
        for p in sorted(set(platforms)):
            self.reliable.send(
                p, AppMessage(topic=cmds.TOPIC_COMMAND, body=body), now, 0, channel=URGENT
            )

    def deploy(self, script: bytes, platforms: Iterable[int], now: float) -> str:
        """Send ``script`` to ``platforms``; returns its SHA-256 (confirmations follow)."""
        sha = hashlib.sha256(script).hexdigest()
        targets = set(platforms)
        self.expected[sha] = targets
        self.confirmed.setdefault(sha, set())
        for chunk in cmds.chunks(script, sha):
            self.send(chunk, targets, now)
        self.deployed_sha = sha
        return sha

    def outcomes(self, command: str) -> dict[int, tuple[bool, str]]:
        """Per platform, the latest ``(ok, message)`` it answered to commands named
        ``command`` (:func:`~actorswarm.engine.commands.outcome`)."""
        out: dict[int, tuple[bool, str]] = {}
        for record in self.replies:
            said = cmds.outcome(record.reply, command)
            if said is not None:
                out[record.platform] = said
        return out

    @property
    def listed(self) -> set[int]:
        """Platforms heard of only from a star master's roster: nothing of their own
        reached this ground station (the master's link to them is no proof of its own)."""
        return set(self.heard) - self.direct

    def missing(self, sha: str) -> list[int]:
        return sorted(self.expected.get(sha, set()) - self.confirmed.get(sha, set()))

    def start(self, now: float, *, force: bool = False, began: float | None = None) -> float | None:
        """Start the script deployed last on every platform expected to run it (refused,
        :class:`NotConfirmed`, while one has not confirmed it, unless ``force``).

        ``began`` is the task's start on the swarm's shared clock (UTC seconds: what every
        platform counts the task's time from, :class:`~actorswarm.engine.commands.Start`);
        the caller's clock, since this station is given time and never reads one. When a
        platform that confirmed the script runs it already, its task's start is sent
        instead, so platforms started later join the same task. Returns what was sent."""
        sha = self.deployed_sha
        if not sha:
            raise RuntimeError("nothing deployed: deploy a script first")
        missing = self.missing(sha)
        if missing and not force:
            raise NotConfirmed(sha, missing)
        began = self.began.get(sha, began)
        self.send(cmds.Start(sha256=sha, began=began), self.expected[sha], now)
        return began

    def event(
        self,
        name: str,
        now: float,
        *,
        platforms: Iterable[int] | None = None,
        actors: Iterable[str] = (),
    ) -> None:
        """Inject an event into the swarm (every platform heard, or only ``platforms``)."""
        self._occasions += 1
        targets = set(self.heard) if platforms is None else set(platforms)
        command = cmds.Inject(
            event=name, actors=sorted(actors), occasion=f"gs{self.incarnation}:{self._occasions}"
        )
        self.send(command, targets, now)

    def renew(self, incarnation: int) -> None:
        """Become a new session (``incarnation``, above every earlier session's): what is
        in flight is dropped. The platforms accept one ground-station session at a time,
        the newest; a long-lived session (a recorder) that a newer one displaced renews
        itself once that one is done, to be answered again."""
        if incarnation <= self.incarnation:
            raise ValueError(f"incarnation {incarnation} is not above {self.incarnation}")
        self.incarnation = incarnation
        # What the old session queued or gave up is dropped with its streams; packets
        # already numbered are still sent.
        self._out.incarnation = incarnation
        self._out.seq = 0
        self._out.queued.clear()
        self._out.failures.clear()
        self.reliable = Reliable(self.config, self._out)
        self.unreachable.clear()

    # --- host interface -----------------------------------------------------------------

    def receive_packet(self, packet: Packet, now: float) -> None:
        """A packet the host's pipeline checked and decoded: the one way in."""
        body = packet.body
        sender = packet.sender
        if sender == wire.GROUND_STATION or packet.swarm != self.swarm:
            return
        self.direct.add(sender)
        if isinstance(body, Heartbeat):
            self.heard[sender] = now
            self.state[sender] = (packet.incarnation, body.is_master, body.epoch)
            if body.is_master and body.roster:
                self._on_master_heartbeat(sender, body, now)
        elif isinstance(body, RosterChunk):
            if sender == self._roster_master and self.roster.on_chunk(body):
                self._learn_roster(now)
        elif isinstance(body, Ack):
            if body.dst == wire.GROUND_STATION and body.dst_incarnation == self.incarnation:
                self.acked[sender] = now
                self.reliable.on_ack(sender, body, now)
            elif body.dst == wire.GROUND_STATION and body.dst_incarnation > self.incarnation:
                self.other_session_heard = now
        elif isinstance(body, Data) and body.dst == wire.GROUND_STATION:
            self.acked[sender] = now
            delivered, ack = self.reliable.on_data(sender, packet.incarnation, body)
            if ack is not None:
                self._emit(sender, ack)
            for _, payload in delivered:
                if isinstance(payload, AppMessage) and payload.topic == cmds.TOPIC_REPLY:
                    self._on_reply(sender, payload.body, now)

    def _on_master_heartbeat(self, master: int, hb: Heartbeat, now: float) -> None:
        """A star master's heartbeat: its members count as heard while it lists them."""
        if master != self._roster_master:
            if (
                self._roster_master is not None
                and hb.epoch < self.state.get(self._roster_master, (0, False, 0))[2]
            ):
                return  # an older master's heartbeat: keep the newer roster
            self._roster_master = master
            self.roster = RosterView()
        if self.roster.on_heartbeat(hb.epoch, hb):
            if now - self._roster_asked >= self.config.retry_cap:
                self._roster_asked = now
                self._emit(master, RosterRequest(epoch=hb.epoch, version=0))
            return
        self._learn_roster(now)

    def _learn_roster(self, now: float) -> None:
        for platform in self.roster.removed:
            if platform not in self.roster.members:
                self.heard.pop(platform, None)
                self.state.pop(platform, None)
        self.roster.removed.clear()
        epoch = self.roster.epoch
        for platform, incarnation in self.roster.members.items():
            self.heard[platform] = now
            if self.state.get(platform, (-1, False, -1))[2] <= epoch:
                self.state[platform] = (incarnation, False, epoch)

    def _on_reply(self, sender: int, body: bytes, now: float) -> None:
        try:
            reply = cmds.decode_reply(body)
        except cmds.CommandError:
            self.counters["drop:reply"] = self.counters.get("drop:reply", 0) + 1
            return
        if isinstance(reply, cmds.DeployAck):
            self.confirmed.setdefault(reply.sha256, set()).add(sender)
            if reply.began is not None:
                # The swarm's first start; platforms should agree, and the earliest is the
                # one a platform that started late cannot have invented.
                self.began[reply.sha256] = min(
                    reply.began, self.began.get(reply.sha256, reply.began)
                )
        self.replies.append(ReplyRecord(now, sender, reply))

    def tick(self, now: float) -> None:
        self.reliable.tick(now)
        for failure in self._out.failures:
            if failure.dst is not None:
                self.unreachable[failure.dst] = now
        self._out.failures.clear()

    def next_deadline(self) -> float | None:
        return self.reliable.next_deadline()

    def ready(self) -> Ready:
        """What to send since the last call, taken at once (the one way out): the packets
        made directly (acknowledgements, roster requests) first, then the streams', all on
        the urgent channel; never events (replies are kept in :attr:`replies`)."""
        self._out.number_queued(URGENT)
        return self._out.take()

    @property
    def has_output(self) -> bool:
        return self._out.pending

    def _emit(self, dst: int, body: wire.Body) -> None:
        self._out.encode(dst, body, URGENT)
