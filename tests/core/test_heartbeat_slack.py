"""Heartbeat slack: a heartbeat due soon rides on a wake the host makes anyway.

The hosts here wake as a daemon's loop does: for a packet (through a pipeline's guard, then
tick when the node is :meth:`~actorswarm.core.node.Node.due`) or at the node's deadline, and
count their wakes. A master and two members, a perfect link.
"""

from __future__ import annotations

import heapq
import itertools
import math
import random

import pytest

from actorswarm.core.config import ConfigError, CoreConfig
from actorswarm.core.node import Node
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline

SWARM = "slack"
LATENCY = 0.002


class _Unused:
    """The pipelines' transport: the hosts send what they take from ``ready()`` themselves."""

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        raise AssertionError("the hosts send what they take from ready() themselves")


class Hosts:
    """Nodes driven like daemons: every wake is a receive-and-tick or a tick."""

    def __init__(
        self,
        config: CoreConfig,
        ids: tuple[int, ...] = (1, 2, 3),
        jitter: float = 0.0,
        busy: dict[int, float] | None = None,
    ) -> None:
        self.nodes = {i: Node(i, swarm=SWARM, incarnation=1, config=config, now=0.0) for i in ids}
        self.pipelines = {
            i: Pipeline(n, _Unused(), PacketGuard.insecure()) for i, n in self.nodes.items()
        }
        #: (time, order, platform, packet) — a packet of None is a wake of its own.
        self.queue: list[tuple[float, int, int, bytes | None]] = []
        self.order = itertools.count()
        self.wakes = dict.fromkeys(ids, 0)
        #: (time, sender) of every heartbeat sent.
        self.beats: list[tuple[float, int]] = []
        #: Every packet takes LATENCY plus up to ``jitter`` more (a loaded host, a radio).
        self.jitter = jitter
        self.rng = random.Random(7)
        #: Platform -> how many more times a second it wakes, at random (other platforms'
        #: packets, as a busy master's do); a heartbeat due soon goes out on such a wake.
        self.busy = busy or {}
        for platform in self.busy:
            self._busy_wake(platform, 0.0)

    def _busy_wake(self, platform: int, now: float) -> None:
        at = now + self.rng.expovariate(self.busy[platform])
        heapq.heappush(self.queue, (at, next(self.order), platform, None))

    def _send(self, nid: int, now: float) -> None:
        for out in self.nodes[nid].ready().packets:
            if out.kind == "Heartbeat":
                self.beats.append((now, nid))
            for dst in [d for d in self.nodes if d != nid] if out.dst is None else [out.dst]:
                delay = LATENCY + self.rng.uniform(0.0, self.jitter)
                heapq.heappush(self.queue, (now + delay, next(self.order), dst, out.data))

    def run(self, end: float) -> None:
        now = 0.0
        while True:
            due = {i: n.next_deadline() for i, n in self.nodes.items()}
            nid, t_tick = min(((i, t) for i, t in due.items() if t is not None), key=lambda x: x[1])
            t_packet = self.queue[0][0] if self.queue else math.inf
            now = max(now, min(t_tick, t_packet))
            if now > end:
                return
            if t_packet <= t_tick:
                _, _, nid, data = heapq.heappop(self.queue)
                if data is None:
                    self._busy_wake(nid, now)
                else:
                    self.pipelines[nid].receive(data, now)
            if self.nodes[nid].due(now):  # as the daemon's endpoint asks
                self.nodes[nid].tick(now)
            self.wakes[nid] += 1
            self._send(nid, now)


def _settled(
    slack: float | None, jitter: float = 0.0, busy: dict[int, float] | None = None
) -> Hosts:
    hosts = Hosts(CoreConfig(heartbeat_slack=slack), jitter=jitter, busy=busy)
    hosts.run(3.0)
    assert all(n.master == 1 for n in hosts.nodes.values()), "setup: 1 is the master"
    hosts.wakes = dict.fromkeys(hosts.wakes, 0)
    hosts.beats.clear()
    return hosts


def test_a_members_heartbeats_ride_on_its_masters_and_keep_their_rate() -> None:
    """Without slack a member wakes twice per interval (its master's heartbeat, its own);
    with 30 ms its heartbeats ride on its master's and it wakes once. Either way it
    sends one heartbeat per interval, and no gap exceeds the interval plus the slack."""
    exact, slack = _settled(None), _settled(0.03)
    exact.run(13.0)
    slack.run(13.0)
    for member in (2, 3):
        sent = [t for t, n in slack.beats if n == member]
        assert len(sent) == pytest.approx(len([t for t, n in exact.beats if n == member]), abs=2)
        assert len(sent) == pytest.approx(100, abs=2)
        assert max(b - a for a, b in itertools.pairwise(sent)) <= 0.1 + 0.03 + 1e-9
        assert exact.wakes[member] >= 195, exact.wakes
        assert slack.wakes[member] <= 110, slack.wakes


@pytest.mark.parametrize(
    ("jitter", "busy"),
    [(0.02, {}), (0.0, {1: 30.0}), (0.02, {1: 30.0}), (0.02, {1: 100.0})],
)
def test_the_ride_holds_when_the_masters_heartbeats_come_off_their_schedule(
    jitter: float, busy: dict[int, float]
) -> None:
    """Each packet takes 2 ms plus up to ``jitter`` more, and the master wakes ``busy``
    more times a second (other platforms' packets), sending its heartbeat up to a slack
    early on such a wake: its heartbeats arrive off their schedule. A member's heartbeats
    still ride on them, one wake per interval (a window of one slack before its time lost
    the master's at every early one and woke about 1.5 times per interval with a busy
    master), one heartbeat per interval, no gap off the interval by more than two slacks."""
    hosts = _settled(0.03, jitter, busy)
    hosts.run(13.0)
    for member in (2, 3):
        sent = [t for t, n in hosts.beats if n == member]
        assert len(sent) == pytest.approx(100, abs=2)
        gaps = [b - a for a, b in itertools.pairwise(sent)]
        assert min(gaps) >= 0.1 - 0.06 - 1e-9
        assert max(gaps) <= 0.1 + 0.06 + 1e-9
        assert hosts.wakes[member] <= 103, hosts.wakes


@pytest.mark.parametrize("busy", [{2: 200.0}, {1: 30.0, 2: 200.0}, {1: 30.0, 2: 20.0}])
def test_a_member_woken_often_keeps_its_heartbeat_rate(busy: dict[int, float]) -> None:
    """Member 2 wakes ``busy[2]`` more times a second (a stream of packets for it): its
    heartbeats still go out once per interval, on the phase they keep, not at the first
    wake of each window (that would be up to one per interval less two slacks: a third
    more heartbeats on a shared channel at 200 wakes a second)."""
    hosts = _settled(0.03, 0.02, busy)
    hosts.run(13.0)
    sent = [t for t, n in hosts.beats if n == 2]
    assert len(sent) == pytest.approx(100, abs=2)
    gaps = [b - a for a, b in itertools.pairwise(sent)]
    assert min(gaps) >= 0.1 - 0.06 - 1e-9 and max(gaps) <= 0.1 + 0.06 + 1e-9, gaps


def test_the_slack_is_checked() -> None:
    with pytest.raises(ConfigError, match="heartbeat_slack"):
        CoreConfig(heartbeat_slack=0.06)
    with pytest.raises(ConfigError, match="heartbeat_slack"):
        CoreConfig(heartbeat_slack=-0.01)
    assert CoreConfig(heartbeat_slack=0.05).heartbeat_slack == 0.05
