"""A simulated swarm: real core :class:`~actorswarm.core.node.Node` objects on a simulated radio.

Theory of operation
-------------------
:class:`SimSwarm` is a host like the daemon, with virtual time instead of the wall clock and
:class:`~actorswarm.sim.radio.SimRadio` instead of Zenoh. For each platform it delivers
packets, calls ``tick`` at the node's own ``next_deadline``, and takes the node's output
with one ``ready()`` per round: transmits its packets and hands its events to the invariant
checker and to any listeners (workloads, the task engine later). Faults are injected through
the radio (loss, bursts, latency, duplication, reordering, bandwidth, partitions) and through
:meth:`SimSwarm.crash` and :meth:`SimSwarm.restart` (a new incarnation with fresh state).

Everything random derives from ``seed``: the radio's faults and each node's heartbeat phase
(``random.Random`` seeded with a string, which Python hashes deterministically). The same seed
and the same calls replay the same run, event for event.
"""

from __future__ import annotations

import functools
import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from actorswarm.core import wire
from actorswarm.core.config import CoreConfig
from actorswarm.core.events import (
    BecameMaster,
    CoreEvent,
    HandshakeComplete,
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.membership.roster import RosterPool
from actorswarm.core.node import Node
from actorswarm.core.wire import Packet
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline
from actorswarm.sim.invariants import InvariantChecker
from actorswarm.sim.port import RadioPort, Security, SimKeys
from actorswarm.sim.radio import LinkModel, SimRadio, Transmission
from actorswarm.sim.scheduler import Scheduler, Timer

Listener = Callable[[float, Node, CoreEvent], None]


@dataclass(frozen=True, slots=True)
class LogEntry:
    """One event of the run: at ``t``, ``platform`` (in ``incarnation``) reported ``event``."""

    t: float
    platform: int
    incarnation: int
    event: CoreEvent | str


@dataclass(slots=True)
class MasterRecord:
    t: float
    platform: int
    epoch: int
    handshake_done: float | None = None


@dataclass(slots=True)
class _Host:
    node: Node
    pipeline: Pipeline
    timer: Timer | None = None
    timer_at: float = float("inf")
    alive: bool = True


@dataclass(slots=True)
class SwarmStats:
    """Counters of the host itself (for benchmarks and sanity checks)."""

    deliveries: int = 0
    ticks: int = 0
    spins: int = 0
    events: int = 0
    extra: dict[str, int] = field(default_factory=dict)


class SimSwarm:
    """A swarm of ``platforms`` (a count, meaning IDs 1..n, or explicit IDs) in virtual time.

    ``log_membership`` keeps join/leave events in :attr:`log` (off for very large swarms,
    where they number N²). ``settle`` is the invariant checker's tolerance window; by default
    long enough for a leave, a join and a few heartbeats. ``security`` is how packets are
    protected (:mod:`actorswarm.sim.port`): by default each platform seals and checks them
    with the swarm's keys, as a daemon does.
    """

    def __init__(
        self,
        platforms: int | Iterable[int],
        *,
        seed: int = 0,
        config: CoreConfig | None = None,
        link: LinkModel | None = None,
        swarm: str = "sim",
        log_membership: bool = True,
        settle: float | None = None,
        sample_every: float | None = None,
        security: Security = "keys",
    ) -> None:
        ids = list(range(1, platforms + 1)) if isinstance(platforms, int) else sorted(platforms)
        if not ids:
            raise ValueError("a swarm needs at least one platform")
        if len(set(ids)) != len(ids):
            raise ValueError("platform IDs must be unique")
        self.seed = seed
        self.config = config or CoreConfig()
        self.swarm = swarm
        #: The star members' rosters, shared where equal (10 000 copies of a roster of
        #: 10 000 were most of a 10 000-platform run's memory).
        self.rosters = RosterPool()
        self.scheduler = Scheduler()
        #: The swarm's keys (from the seed): every platform seals and checks its packets.
        self.keys = SimKeys(seed, security)
        # Receivers check and decode through their own guards; the radio's shared decoder
        # serves only a tap that asks a transmission for its packet.
        self.radio: SimRadio[Packet] = SimRadio(
            self.scheduler, random.Random(f"{seed}:radio"), link or LinkModel(), decoder=wire.decode
        )
        self.hosts: dict[int, _Host] = {}
        self.incarnations: dict[int, int] = {}
        self.log: list[LogEntry] = []
        self.masters: list[MasterRecord] = []
        self.listeners: list[Listener] = []
        self.stats = SwarmStats()
        self._log_membership = log_membership
        cfg = self.config
        self.settle = (
            settle
            if settle is not None
            else cfg.t_leave + cfg.t_join + 5 * cfg.heartbeat_interval + cfg.handshake_timeout
        )
        self.booted: dict[int, float] = {}
        self.checker = InvariantChecker(
            self.settle,
            incarnation_of=lambda p: self.incarnations.get(p, -1),
            booted_at=lambda p: self.booted.get(p, 0.0),
            reboot_blindness=cfg.t_leave + cfg.t_join,
        )
        for p in ids:
            self._boot(p, 0)
        self._sample_every = sample_every or cfg.heartbeat_interval
        self.scheduler.at(0.0, self._sample)

    # --- time -----------------------------------------------------------------------------

    @property
    def now(self) -> float:
        return self.scheduler.now

    def run_until(self, t: float) -> None:
        """Run every event up to virtual time ``t``."""
        self.scheduler.run_until(t)

    def at(self, t: float, fn: Callable[..., object], *args: Any) -> Timer:
        """Call ``fn(*args)`` at virtual time ``t`` (for scripted faults and workloads)."""
        return self.scheduler.at(t, fn, *args)

    # --- platforms ---------------------------------------------------------------------------

    @property
    def nodes(self) -> dict[int, Node]:
        """Live platforms' nodes by ID."""
        return {p: h.node for p, h in self.hosts.items() if h.alive}

    def node(self, platform: int) -> Node:
        host = self.hosts.get(platform)
        if host is None or not host.alive:
            raise KeyError(f"platform {platform} is not running")
        return host.node

    def _boot(self, platform: int, incarnation: int) -> None:
        node = Node(
            platform,
            swarm=self.swarm,
            incarnation=incarnation,
            config=self.config,
            now=self.now,
            rng=random.Random(f"{self.seed}:{platform}:{incarnation}"),
            roster_pool=self.rosters,
        )
        self.incarnations[platform] = incarnation
        if incarnation > 0:
            self.booted[platform] = self.now
        guard = self.keys.guard(max_bytes=self.config.max_packet_bytes)
        self.hosts[platform] = _Host(node, Pipeline(node, RadioPort(self.radio, platform), guard))
        self.radio.attach(platform, functools.partial(self._deliver, platform))
        self._schedule(platform, self.now)

    def crash(self, platform: int) -> None:
        """Stop ``platform`` at once: it sends, hears and remembers nothing more."""
        host = self.hosts.get(platform)
        if host is None or not host.alive:
            return
        host.alive = False
        if host.timer is not None:
            host.timer.cancel()
        self.radio.detach(platform)
        self.log.append(LogEntry(self.now, platform, host.node.incarnation, "crash"))

    def restart(self, platform: int) -> None:
        """Boot ``platform`` again in a new incarnation with fresh state."""
        host = self.hosts.get(platform)
        if host is not None and host.alive:
            self.crash(platform)
        incarnation = self.incarnations.get(platform, -1) + 1
        self._boot(platform, incarnation)
        self.log.append(LogEntry(self.now, platform, incarnation, "restart"))

    def add(self, platform: int) -> None:
        """A new platform powers up and joins."""
        if platform in self.hosts and self.hosts[platform].alive:
            raise ValueError(f"platform {platform} is already running")
        self.restart(platform)

    def partition(self, groups: Iterable[Iterable[int]]) -> None:
        groups = [list(g) for g in groups]
        self.radio.partition(groups)
        self.log.append(LogEntry(self.now, 0, 0, f"partition {groups}"))

    def heal(self) -> None:
        self.radio.heal()
        self.log.append(LogEntry(self.now, 0, 0, "heal"))

    def components(self) -> list[frozenset[int]]:
        """Connected components of the live platforms."""
        return self.radio.components(self.nodes)

    # --- driving nodes ---------------------------------------------------------------------

    def call(self, platform: int, fn: Callable[[Node], object]) -> object:
        """Run ``fn(node)`` on a live platform now (an application call) and service it."""
        result = fn(self.node(platform))
        self._service(platform)
        return result

    def _deliver(self, platform: int, tx: Transmission[Packet], now: float) -> None:
        host = self.hosts[platform]
        if not host.alive:
            return
        self.stats.deliveries += 1
        # Checked and decoded by this receiver's guard, as on a real platform: a damaged,
        # duplicated or replayed packet is refused there and counted by reason.
        host.pipeline.receive(tx.data, now)
        if host.node.has_ready:
            self._service(platform)

    def _tick(self, platform: int) -> None:
        host = self.hosts[platform]
        if not host.alive:
            return
        host.timer = None
        host.timer_at = float("inf")
        self.stats.ticks += 1
        host.node.tick(self.now)
        self._service(platform, after_tick=True)

    def _schedule(self, platform: int, t: float) -> None:
        host = self.hosts[platform]
        if t >= host.timer_at:
            return
        if host.timer is not None:
            host.timer.cancel()
        host.timer_at = t
        host.timer = self.scheduler.at(t, self._tick, platform)

    def _service(self, platform: int, *, after_tick: bool = False) -> None:
        host = self.hosts[platform]
        node = host.node
        now = self.now
        # Listeners (a task engine) may act on the node while handling its events: loop
        # until it has nothing more to send or report.
        for _ in range(1000):
            ready = node.ready()
            host.pipeline.send(ready.packets)
            if ready.events:
                self._handle_events(node, ready.events, now)
            if not node.has_ready or not host.alive:
                break
        deadline = node.next_deadline()
        if deadline is not None and host.alive:
            if deadline <= now:
                if after_tick:
                    # A node that still has work right after a tick would spin forever.
                    self.stats.spins += 1
                    deadline = now + 1e-6
                else:
                    deadline = now
            self._schedule(platform, deadline)

    def _handle_events(self, node: Node, events: list[CoreEvent], now: float) -> None:
        self.stats.events += len(events)
        for event in events:
            if isinstance(event, MemberJoined | MemberLeft):
                if self._log_membership:
                    self.log.append(LogEntry(now, node.platform, node.incarnation, event))
            else:
                self.log.append(LogEntry(now, node.platform, node.incarnation, event))
            if isinstance(event, BecameMaster):
                self.masters.append(MasterRecord(now, node.platform, event.epoch))
            elif isinstance(event, HandshakeComplete):
                for rec in reversed(self.masters):
                    if rec.platform == node.platform and rec.epoch == event.epoch:
                        rec.handshake_done = now
                        break
            self.checker.on_event(now, node, event)
            for listener in self.listeners:
                listener(now, node, event)

    def _sample(self) -> None:
        self.checker.sample(self.now, self.nodes, self.radio.components)
        self.scheduler.after(self._sample_every, self._sample)

    # --- results ---------------------------------------------------------------------------

    def master_of(self, platform: int) -> int | None:
        return self.node(platform).master

    def current_masters(self) -> list[int]:
        return sorted(p for p, n in self.nodes.items() if n.is_master)

    def formed(self, size: int) -> bool:
        """One master, with the other ``size - 1`` platforms in its view and its handshake
        done (every member acknowledged it): the swarm a benchmark can start measuring."""
        masters = self.current_masters()
        if len(masters) != 1:
            return False
        master = self.node(masters[0])
        return master.handshake_complete and len(master.members) == size - 1

    def finish(self) -> list[str]:
        """End-of-run invariant checks; every violation of the run, as readable lines."""
        return self.checker.finish(self.now, self.nodes, self.radio.components)

    def traffic(self) -> dict[int, dict[str, Any]]:
        return self.radio.traffic.snapshot()

    def guard(self, platform: int) -> PacketGuard:
        """The guard of a live platform (what it refused: ``guard(p).rejected``)."""
        host = self.hosts.get(platform)
        if host is None or not host.alive:
            raise KeyError(f"platform {platform} is not running")
        return host.pipeline.guard
