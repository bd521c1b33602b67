"""The guard between real cores: a swarm whose every packet is sealed and checked elects its
master, passes a barrier and takes the ground station's command, while a network that
duplicates every packet and a captured robot forging operator commands get nowhere.

The network is a tiny deterministic event loop (like the one of ``tests/core/test_node.py``):
every packet arrives after a fixed latency and once more, replayed, a little later.
"""

from __future__ import annotations

import heapq
import itertools
import math

from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

from actorswarm.core.events import AppReceived, BarrierReleased, CoreEvent
from actorswarm.core.node import Node, Outgoing
from actorswarm.core.wire import GROUND_STATION, URGENT, AppMessage, Data, encode
from actorswarm.engine import commands as cmds
from actorswarm.ground.station import GroundStation
from actorswarm.security import PacketGuard

SWARM = "guarded"
KEY = bytes(range(100, 132))
GS_PRIVATE = Ed25519PrivateKey.generate()
LATENCY = 0.002
REPLAY_DELAY = 0.013
IDS = (1, 2, 3)


class GuardedNet:
    def __init__(self) -> None:
        public = GS_PRIVATE.public_key()
        self.nodes = {i: Node(i, swarm=SWARM, incarnation=1) for i in IDS}
        self.guards = {i: PacketGuard(KEY, public) for i in IDS}
        self.gs = GroundStation(swarm=SWARM, incarnation=7)
        self.guards[GROUND_STATION] = PacketGuard(
            KEY, public, gs_private_key=GS_PRIVATE, role="ground"
        )
        self.now = 0.0
        self.queue: list[tuple[float, int, int, bytes]] = []
        self.order = itertools.count()
        self.events: dict[int, list[CoreEvent]] = {i: [] for i in IDS}

    def inject(self, dst: int, data: bytes) -> None:
        heapq.heappush(self.queue, (self.now + LATENCY, next(self.order), dst, data))

    def _send(self, src: int, outgoing: list[Outgoing]) -> None:
        for out in outgoing:
            data = self.guards[src].seal(out.data)
            everyone = [*IDS, GROUND_STATION]
            targets = [d for d in everyone if d != src] if out.dst is None else [out.dst]
            for dst in targets:
                for delay in (LATENCY, REPLAY_DELAY):
                    heapq.heappush(self.queue, (self.now + delay, next(self.order), dst, data))

    def _collect(self) -> None:
        for i, node in self.nodes.items():
            ready = node.ready()
            self._send(i, ready.packets)
            self.events[i].extend(ready.events)
        self._send(GROUND_STATION, self.gs.ready().packets)

    def run_until(self, end: float) -> None:
        for _ in range(200_000):
            deadlines = [n.next_deadline() for n in self.nodes.values()]
            deadlines.append(self.gs.next_deadline())
            t_tick = min((t for t in deadlines if t is not None), default=math.inf)
            t_packet = self.queue[0][0] if self.queue else math.inf
            t = min(t_tick, t_packet)
            if t > end:
                self.now = end
                return
            self.now = max(self.now, t)
            if t_packet <= t_tick:
                _, _, dst, data = heapq.heappop(self.queue)
                packet = self.guards[dst].check(data, self.now)
                if packet is not None:
                    if dst == GROUND_STATION:
                        self.gs.receive_packet(packet, self.now)
                    else:
                        self.nodes[dst].receive_packet(packet, self.now)
            else:
                for node in self.nodes.values():
                    deadline = node.next_deadline()
                    if deadline is not None and deadline <= self.now:
                        node.tick(self.now)
                deadline = self.gs.next_deadline()
                if deadline is not None and deadline <= self.now:
                    self.gs.tick(self.now)
            self._collect()
        raise AssertionError(f"did not reach t={end}")


def _commands(net: GuardedNet, platform: int) -> list[cmds.Command]:
    return [
        cmds.decode_command(e.body)
        for e in net.events[platform]
        if isinstance(e, AppReceived) and e.topic == cmds.TOPIC_COMMAND
    ]


def test_a_guarded_swarm_works_and_refuses_replays_and_forged_commands() -> None:
    net = GuardedNet()
    net.run_until(1.5)
    assert all((n.master, n.epoch) == (1, 1) for n in net.nodes.values())

    for i in IDS:
        net.nodes[i].request_barrier(4, len(IDS), net.now)
    net._collect()
    net.run_until(2.5)
    for i in IDS:
        assert [type(e) for e in net.events[i] if isinstance(e, BarrierReleased)] == [
            BarrierReleased
        ], f"platform {i} passes the barrier once"

    # A captured robot (it has the swarm key) forges an operator command to platform 2.
    robot = PacketGuard(KEY, GS_PRIVATE.public_key())
    forged = Data(
        dst=2,
        channel=URGENT,
        seq=1,
        floor=1,
        epoch=0,
        payload=AppMessage(topic=cmds.TOPIC_COMMAND, body=cmds.encode(cmds.Start(sha256="f" * 64))),
    )
    raw = encode(swarm=SWARM, sender=GROUND_STATION, incarnation=99, seq=1, body=forged)
    net.inject(2, robot.seal(raw))
    net.gs.send(cmds.Start(sha256="a" * 64), [2], net.now)
    net._collect()
    net.run_until(3.5)

    assert _commands(net, 2) == [cmds.Start(sha256="a" * 64)], "only the genuine command"
    assert net.guards[2].rejected["unsigned_operator"] == 1
    for i in IDS:
        guard = net.guards[i]
        assert guard.accepted > 0
        assert guard.rejected["replay"] >= guard.accepted - 1, "every copy was refused"
        assert set(guard.rejected) <= {"replay", "unsigned_operator"}
        assert not net.nodes[i].errors
