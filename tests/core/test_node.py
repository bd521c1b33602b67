"""Node glue on a tiny deterministic network: election, hostile bytes, barriers and roles.

The network here is a list-based event loop written for these tests (no simulator): every
outgoing packet reaches its destination(s) after a fixed latency, and each node is ticked at
its own ``next_deadline``. Packets come in as on a platform: through a
:class:`~actorswarm.security.pipeline.Pipeline` whose guard (an insecure one: the frame
only) checks the bytes before the node sees the packet.
"""

from __future__ import annotations

import heapq
import itertools
import math
import zlib
from collections.abc import Callable
from typing import Any

import msgspec
import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.core.events import (
    BarrierFired,
    BarrierReleased,
    BarrierStaleNotice,
    BecameMaster,
    CoreEvent,
    HandshakeComplete,
    RoleDenied,
    RoleGranted,
    SteppedDown,
)
from actorswarm.core.node import Node
from actorswarm.core.ready import Outgoing
from actorswarm.core.wire import (
    NEED_ALL,
    PROTOCOL_VERSION,
    BarrierRequest,
    Data,
    Envelope,
    Heartbeat,
    Release,
    WireError,
    decode,
    encode,
)
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline

SWARM = "test-swarm"
INCARNATION = 1
LATENCY = 0.002
MAX_STEPS = 200_000


class _Unused:
    """The pipelines' transport here: the network takes each node's ``ready()`` itself
    (it reads the events too) and sends nothing through a pipeline."""

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        raise AssertionError("the test network sends what it takes from ready() itself")


def _pipeline(node: Node) -> Pipeline:
    """``node``'s one way in: an insecure guard checks the frame, then ``receive_packet``."""
    return Pipeline(node, _Unused(), PacketGuard.insecure(max_bytes=node.config.max_packet_bytes))


class Net:
    """Nodes joined by a perfect radio with a fixed latency."""

    def __init__(self, ids: list[int], *, config: CoreConfig | None = None) -> None:
        self.config = config or CoreConfig()
        self.nodes = {
            i: Node(i, swarm=SWARM, incarnation=INCARNATION, config=self.config, now=0.0)
            for i in ids
        }
        self._pipelines: dict[int, Pipeline] = {}
        self.now = 0.0
        self._queue: list[tuple[float, int, int, bytes]] = []
        self._order = itertools.count()
        self.events: dict[int, list[tuple[float, CoreEvent]]] = {i: [] for i in ids}
        #: Every packet sent: (sender, packet).
        self.sent: list[tuple[int, Outgoing]] = []

    def pipeline(self, nid: int) -> Pipeline:
        """Node ``nid``'s way in (a new one for a node put in its place)."""
        pipeline = self._pipelines.get(nid)
        if pipeline is None or pipeline.endpoint is not self.nodes[nid]:
            pipeline = self._pipelines[nid] = _pipeline(self.nodes[nid])
        return pipeline

    def _collect(self, nid: int) -> None:
        ready = self.nodes[nid].ready()
        for out in ready.packets:
            self.sent.append((nid, out))
            targets = [d for d in self.nodes if d != nid] if out.dst is None else [out.dst]
            for dst in targets:
                if dst in self.nodes:
                    at = self.now + LATENCY
                    heapq.heappush(self._queue, (at, next(self._order), dst, out.data))
        self.events[nid].extend((self.now, e) for e in ready.events)

    def _next_tick(self) -> float:
        times = [n.next_deadline() for n in self.nodes.values()]
        return min((t for t in times if t is not None), default=math.inf)

    def run_until(self, end: float) -> None:
        for _ in range(MAX_STEPS):
            t_packet = self._queue[0][0] if self._queue else math.inf
            t_tick = self._next_tick()
            t = min(t_packet, t_tick)
            if t > end:
                self.now = end
                return
            self.now = max(self.now, t)
            if t_packet <= t_tick:
                _, _, dst, data = heapq.heappop(self._queue)
                self.pipeline(dst).receive(data, self.now)
                self._collect(dst)
            else:
                for nid, node in sorted(self.nodes.items()):
                    deadline = node.next_deadline()
                    if deadline is not None and deadline <= self.now:
                        node.tick(self.now)
                        self._collect(nid)
        raise AssertionError(f"the network did not reach t={end} in {MAX_STEPS} steps")

    def act(self, nid: int, call: Callable[[Node], Any]) -> Any:
        """Call the application interface of node ``nid`` now and route what it produced."""
        result = call(self.nodes[nid])
        self._collect(nid)
        return result

    def of_type(self, nid: int, kind: type) -> list[Any]:
        return [e for _, e in self.events[nid] if isinstance(e, kind)]

    def releases(self) -> list[tuple[int, int | None, list[int]]]:
        """Every release packet sent: (sender, destination, the platforms it names)."""
        out = []
        for nid, packet in self.sent:
            if packet.kind == "Release":
                rel = decode(packet.data).body
                assert isinstance(rel, Release)
                out.append((nid, packet.dst, [e.platform for e in rel.entries]))
        return out


def _elected(ids: tuple[int, ...] = (1, 2, 3)) -> Net:
    net = Net(list(ids))
    net.run_until(1.5)
    for nid, node in net.nodes.items():
        assert (node.master, node.epoch) == (1, 1), f"setup: node {nid} follows 1 in epoch 1"
    return net


@pytest.mark.parametrize("membership", ["star", "broadcast"])
def test_three_nodes_elect_node_one_in_epoch_one(membership: str) -> None:
    net = Net([1, 2, 3], config=CoreConfig(membership=membership))  # type: ignore[arg-type]
    net.run_until(2.0)
    startup = net.config.startup_wait
    for nid, node in net.nodes.items():
        assert node.view == (1, 2, 3), f"node {nid} view {node.view}"
        assert node.master == 1, f"node {nid} follows {node.master}"
        assert node.epoch == 1, f"node {nid} in epoch {node.epoch}"
        assert node.is_master is (nid == 1)
        assert node.errors == [], node.errors
        assert net.of_type(nid, SteppedDown) == []
    claims = [(t, e) for t, e in net.events[1] if isinstance(e, BecameMaster)]
    assert [e for _, e in claims] == [BecameMaster(epoch=1)], "one claim, epoch 1"
    assert claims[0][0] >= startup, f"claimed at {claims[0][0]}, before startup_wait {startup}"
    assert net.of_type(2, BecameMaster) == [] and net.of_type(3, BecameMaster) == []
    # In a star, 2 and 3 keep quiet while they hear 1 (a lower ID), so 1 claims with an empty
    # view and they join it by following; broadcasting, they were in its view before.
    members = 2 if membership == "broadcast" else 0
    assert net.of_type(1, HandshakeComplete) == [HandshakeComplete(epoch=1, members=members)]
    assert net.nodes[1].handshake_complete


def _state(node: Node) -> tuple[Any, ...]:
    return (
        node.epoch,
        node.master,
        node.is_master,
        node.view,
        node.handshake_complete,
        dict(node.barriers.known),
        sorted(node.barriers.pending),
        sorted(node.roles.held),
        {p: (m.incarnation, m.deadline, m.last_heard) for p, m in node.members.peers.items()},
        node.members.next_deadline(),
    )


def frame(raw: bytes) -> bytes:
    """``raw`` followed by its CRC-32, big-endian: what ``encode`` puts on the air."""
    return raw + zlib.crc32(raw).to_bytes(4, "big")


def _envelope(**changes: Any) -> bytes:
    """An unframed envelope; :func:`frame` it to get past the receiver's frame check."""
    fields: dict[str, Any] = {
        "version": PROTOCOL_VERSION,
        "swarm": SWARM,
        "sender": 2,
        "incarnation": INCARNATION,
        "seq": 10_000,
        "type": 1,
        "body": msgspec.Raw(msgspec.msgpack.encode(Heartbeat(is_master=True, epoch=99, master=2))),
    }
    fields.update(changes)
    return msgspec.msgpack.encode(Envelope(**fields))


_VALID = frame(_envelope())
_FLIPPED = bytes([_VALID[0], _VALID[1] ^ 0x01, *_VALID[2:]])  # version 1 -> 0, CRC unchanged
HOSTILE: list[tuple[str, bytes, str]] = [
    # damaged or random bytes: refused by the length or the frame check
    ("empty", b"", "malformed"),
    ("too-short", b"\x01\x02\x03\x04", "malformed"),
    ("garbage", b"\xff\x00garbage\x13", "checksum"),
    ("truncated", _VALID[:-3], "checksum"),
    ("bit-flipped", _FLIPPED, "checksum"),
    ("unframed", _envelope(), "checksum"),
    ("oversized", b"\x90" * (CoreConfig().max_packet_bytes + 1), "oversized"),
    # a correct CRC over hostile contents: refused by the checks behind the frame check
    ("framed-garbage", frame(b"\xff\x00garbage\x13"), "malformed"),
    ("framed-truncated", frame(_VALID[:-7]), "malformed"),
    ("wrong-swarm", frame(_envelope(swarm="other-swarm")), "swarm"),
    ("wrong-version", frame(_envelope(version=PROTOCOL_VERSION + 1)), "version"),
    ("unknown-type", frame(_envelope(type=42)), "type"),
    ("sender-70000", frame(_envelope(sender=70000)), "malformed"),
    ("negative-seq", frame(_envelope(seq=-1)), "malformed"),
]


def test_hostile_table_starts_from_a_valid_packet() -> None:
    """The hostile envelopes are variations of a packet that every node would accept."""
    packet = decode(_VALID, swarm=SWARM)
    assert (packet.sender, packet.seq) == (2, 10_000)
    body = Heartbeat(is_master=True, epoch=99, master=2)
    sent = encode(swarm=SWARM, sender=2, incarnation=INCARNATION, seq=10_000, body=body)
    assert sent == _VALID, "frame() mirrors encode()"


@pytest.mark.parametrize(
    ("data", "reason"), [(d, r) for _, d, r in HOSTILE], ids=[n for n, _, _ in HOSTILE]
)
def test_hostile_bytes_change_nothing_and_are_counted(data: bytes, reason: str) -> None:
    """Each hostile packet is refused for its reason (the wire says why); on a platform's
    way in, the guard refuses what its frame check or its decoding catches (counted as
    malformed), and the node what is well formed but not for it (another swarm's)."""
    with pytest.raises(WireError) as refused:
        decode(data, swarm=SWARM, max_bytes=CoreConfig().max_packet_bytes)
    assert refused.value.reason == reason
    net = _elected()
    for nid, node in net.nodes.items():
        before = _state(node)
        guard = net.pipeline(nid).guard
        malformed = guard.rejected["malformed"]
        counters = dict(node.counters)
        for _ in range(3):
            assert not net.pipeline(nid).receive(data, net.now) or reason == "swarm"
        assert _state(node) == before, f"node {nid}: {reason} bytes changed its state"
        ready = node.ready()
        assert ready.packets == [], "nothing is sent in answer"
        assert ready.events == [], "nothing is reported upward"
        if reason == "swarm":
            assert node.counters["drop:swarm"] == counters.get("drop:swarm", 0) + 3
        else:
            assert guard.rejected["malformed"] == malformed + 3, dict(guard.rejected)
            assert dict(node.counters) == counters, "the node never saw it"
        assert node.errors == []
    net.run_until(2.5)
    assert all((n.master, n.epoch) == (1, 1) for n in net.nodes.values()), "still organized"


def test_packet_from_old_incarnation_is_dropped() -> None:
    net = _elected()
    node = net.nodes[3]
    before = _state(node)
    stale = encode(
        swarm=SWARM,
        sender=1,
        incarnation=INCARNATION - 1,
        seq=1,
        body=Heartbeat(is_master=True, epoch=50, master=1),
    )
    node.receive_packet(decode(stale), net.now)
    assert node.counters["drop:old_incarnation"] == 1, dict(node.counters)
    assert _state(node) == before, "a leftover of an earlier incarnation changes nothing"
    assert node.ready().events == []


def test_own_packets_are_dropped() -> None:
    net = _elected()
    node = net.nodes[2]
    before = _state(node)
    echo = encode(
        swarm=SWARM,
        sender=2,
        incarnation=INCARNATION,
        seq=1,
        body=Heartbeat(is_master=True, epoch=50, master=2),
    )
    node.receive_packet(decode(echo), net.now)
    assert node.counters["drop:own"] == 1
    assert _state(node) == before


@pytest.mark.parametrize("asked_at", [0.05, 1.5], ids=["before-election", "after-election"])
def test_barrier_releases_all_three_with_indices(asked_at: float) -> None:
    net = Net([1, 2, 3])
    net.run_until(asked_at)
    generations = {
        nid: net.act(nid, lambda n: n.request_barrier(1, 3, net.now)) for nid in net.nodes
    }
    assert set(generations.values()) == {0}
    net.run_until(asked_at + 2.0)
    indices = []
    for nid in net.nodes:
        released = net.of_type(nid, BarrierReleased)
        assert len(released) == 1, f"node {nid} released {len(released)} times: {released}"
        (event,) = released
        assert (event.key, event.generation, event.outcome) == (1, 0, "complete")
        assert event.chosen and event.size == 3
        assert event.index == nid, "default bid is the platform ID: index follows the ID"
        indices.append(event.index)
    assert sorted(indices) == [1, 2, 3]
    fired = net.of_type(1, BarrierFired)
    assert [(f.generation, f.chosen) for f in fired] == [(0, {1: (0, 1), 2: (0, 2), 3: (0, 3)})]
    assert all(node.barriers.pending == {} for node in net.nodes.values())


def test_a_barrier_of_all_waits_for_every_member_not_for_a_joiner_in_its_place() -> None:
    """A platform that follows the master before the master admitted it may ask to pass a
    barrier of all. Its request must not stand in for a member's: the barrier fires when
    every platform of the master's view has asked, and takes the joiner along."""
    net = _elected()
    net.nodes[4] = Node(4, swarm=SWARM, incarnation=INCARNATION, config=net.config, now=net.now)
    net.events[4] = []
    while net.nodes[4].master != 1:
        net.run_until(net.now + 0.01)
    assert 4 not in net.nodes[1].members, "setup: 4 follows 1, and 1 has not admitted it"
    for nid in (4, 1, 2):
        net.act(nid, lambda n: n.request_barrier(1, NEED_ALL, net.now))
    net.run_until(net.now + 0.05)
    assert net.of_type(1, BarrierFired) == [], "member 3 has not asked yet"
    net.act(3, lambda n: n.request_barrier(1, NEED_ALL, net.now))
    net.run_until(net.now + 1.0)
    (fired,) = net.of_type(1, BarrierFired)
    assert sorted(fired.chosen) == [1, 2, 3, 4]
    for nid in net.nodes:
        assert [e.chosen for e in net.of_type(nid, BarrierReleased)] == [True], nid


def test_a_release_of_one_goes_to_it_alone_and_the_others_catch_up_by_a_stale_notice() -> None:
    """A release that names one platform besides the master is sent to that platform only:
    the others do not wake for it. One that asks for the key later, with the generation it
    last knew, is told its request is stale and may ask again (the engine does); a release of
    several goes to everyone."""
    net = Net([1, 2, 3])
    net.run_until(1.5)
    assert all(n.master == 1 for n in net.nodes.values()), "setup: 1 is master"
    assert net.act(2, lambda n: n.request_barrier(7, 1, net.now)) == 0
    net.run_until(net.now + 0.5)
    assert net.releases() == [(1, 2, [2])], "the release of 2 alone went to 2 alone"
    assert [e.generation for e in net.of_type(2, BarrierReleased)] == [0]
    assert net.act(3, lambda n: n.request_barrier(7, 1, net.now)) == 0, "3 did not hear of it"
    net.run_until(net.now + 0.5)
    assert net.of_type(3, BarrierReleased) == []
    assert net.of_type(3, BarrierStaleNotice) == [
        BarrierStaleNotice(key=7, generation=0, current=1)
    ]
    assert net.act(3, lambda n: n.request_barrier(7, 1, net.now)) == 1
    net.run_until(net.now + 0.5)
    assert [e.generation for e in net.of_type(3, BarrierReleased)] == [1]
    assert net.releases()[1:] == [(1, 3, [3])]
    for nid in (2, 3):
        net.act(nid, lambda n: n.request_barrier(8, 2, net.now))
    net.run_until(net.now + 0.5)
    assert net.releases()[2:] == [(1, None, [2, 3])], "a release of two is one broadcast"


def _lose_first_request(node: Node) -> list[int]:
    """The radio loses the first barrier request ``node`` sends; the list returned fills
    with one entry when it has."""
    lost: list[int] = []
    original = node.ready

    def ready() -> Any:
        out = original()
        for i, packet in enumerate(out.packets):
            body = decode(packet.data).body
            if not lost and isinstance(body, Data) and isinstance(body.payload, BarrierRequest):
                del out.packets[i]
                lost.append(body.seq)
                break
        return out

    node.ready = ready  # type: ignore[method-assign]
    return lost


@pytest.mark.parametrize("membership", ["star", "broadcast"])
def test_a_member_the_master_awaits_sends_its_lost_request_again_at_once(membership: str) -> None:
    """A barrier of all waits for one member whose request was lost. Its own next retry is
    far off (a slow retry here; on a shared channel, seconds); the master's heartbeat names
    it as awaited and it sends the request again at once."""
    config = CoreConfig(membership=membership)  # type: ignore[arg-type]
    net = Net([1, 2, 3], config=config)
    # Platform 3 alone retries slowly: its first retry would be 3 s after its request.
    slow = CoreConfig(membership=membership, retry_base=3.0, retry_cap=3.0)  # type: ignore[arg-type]
    net.nodes[3] = Node(3, swarm=SWARM, incarnation=INCARNATION, config=slow, now=0.0)
    lost = _lose_first_request(net.nodes[3])
    net.run_until(1.5)
    assert {n.master for n in net.nodes.values()} == {1}, "setup: one swarm under 1"
    asked = net.now
    for nid in (1, 2, 3):
        net.act(nid, lambda n: n.request_barrier(1, NEED_ALL, net.now))
    net.run_until(asked + 1.0)
    assert len(lost) == 1, "setup: 3's request was lost"
    fired = net.of_type(1, BarrierFired)
    assert len(fired) == 1, "the barrier did not fire within 1 s of the requests"
    assert sorted(fired[0].chosen) == [1, 2, 3]
    ((at, _),) = [(t, e) for t, e in net.events[3] if isinstance(e, BarrierReleased)]
    assert at - asked < 0.5, f"3 passed {at - asked:.2f} s after asking: not hurried"
    assert net.nodes[3].counters["hurried"] >= 1


def test_role_quota_one_grants_one_denies_other_then_regrants() -> None:
    net = _elected()
    net.act(2, lambda n: n.claim_role("leader", 1, net.now))
    net.run_until(1.6)
    net.act(3, lambda n: n.claim_role("leader", 1, net.now))
    net.run_until(2.0)
    assert net.of_type(2, RoleGranted) == [RoleGranted(role="leader")]
    assert net.of_type(3, RoleDenied) == [RoleDenied(role="leader", holders=(2,))]
    assert net.of_type(3, RoleGranted) == []
    assert net.nodes[1].role_holders("leader") == (2,)
    net.act(2, lambda n: n.release_role("leader", net.now))
    net.run_until(2.5)
    assert net.of_type(3, RoleGranted) == [RoleGranted(role="leader")], "3 gets the free slot"
    assert net.nodes[1].role_holders("leader") == (3,)
    assert "leader" in net.nodes[3].roles.held
    assert "leader" not in net.nodes[2].roles.held


def _heartbeat(seq: int) -> bytes:
    return encode(
        swarm=SWARM,
        sender=2,
        incarnation=0,
        seq=seq,
        body=Heartbeat(is_master=False, epoch=0, master=0),
    )


def test_three_distinct_heartbeats_join() -> None:
    node = Node(1, swarm=SWARM)
    for seq, t in ((1, 0.0), (2, 0.1), (3, 0.2)):
        node.receive_packet(decode(_heartbeat(seq)), t)
    assert node.view == (1, 2)


def test_duplicated_heartbeat_does_not_count_twice_for_join() -> None:
    node = Node(1, swarm=SWARM)
    for t in (0.0, 0.001, 0.002):
        node.receive_packet(decode(_heartbeat(1)), t)
    assert node.view == (1,), "one heartbeat, received three times, is still one heartbeat"


def test_batch_processes_ground_station_traffic_first() -> None:
    from actorswarm.core.wire import AppMessage, Data, encode

    node = Node(2, swarm="s", now=0.0)

    def app(sender: int, topic: str) -> bytes:
        body = Data(
            dst=2,
            channel=0 if sender == 0 else 1,
            seq=1,
            floor=1,
            epoch=0,
            payload=AppMessage(topic=topic, body=b""),
        )
        return encode(swarm="s", sender=sender, incarnation=0, seq=1, body=body)

    pipeline = _pipeline(node)
    accepted = pipeline.receive_all([app(5, "swarm"), b"junk", app(0, "operator")], 0.1)
    topics = [e.topic for e in node.ready().events if hasattr(e, "topic")]
    assert topics == ["operator", "swarm"] and accepted == 2
    assert pipeline.guard.rejected["malformed"] == 1, "the junk stops at the guard"


def test_every_body_type_but_heartbeats_has_one_handler() -> None:
    """Dispatch is one table from body type to handler: a body type the wire can carry and
    the table lacks would be dropped as an internal error."""
    import typing

    from actorswarm.core.node import intake as node_module
    from actorswarm.core.wire import Body, Heartbeat

    bodies = set(typing.get_args(Body)) - {Heartbeat}
    assert set(node_module._BODY_HANDLERS) == bodies
