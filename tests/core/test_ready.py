"""The output contract of a node: one collector, taken at once with ``ready()``.

Packets come urgent channel first, then in the order they were numbered, and they are
numbered in the order the node's parts produced them (a stream's retransmission queued
before a heartbeat is numbered before it); ``ready()`` leaves nothing behind; barrier
firings and messages given up arrive through it as events.
"""

from __future__ import annotations

from actorswarm.core.config import CoreConfig
from actorswarm.core.delivery.bulletin import BulletinBoard
from actorswarm.core.delivery.reliable import Reliable
from actorswarm.core.events import (
    BarrierFired,
    BarrierReleased,
    BecameMaster,
    DeliveryFailed,
)
from actorswarm.core.node import Node
from actorswarm.core.ready import Collector, Outgoing
from actorswarm.core.wire import (
    NORMAL,
    URGENT,
    AppMessage,
    Data,
    Heartbeat,
    decode,
)

SWARM = "ready-swarm"


def numbered(packets: list[Outgoing]) -> list[tuple[str, int, int]]:
    """(kind, channel, packet sequence) of each packet, decoded from its bytes."""
    out = []
    for o in packets:
        packet = decode(o.data, swarm=SWARM)
        assert type(packet.body).__name__ == o.kind
        out.append((o.kind, o.channel, packet.seq))
    return out


def lone_node(*, boot_wait: float = 100.0, delivery_deadline: float = 10.0) -> Node:
    """Platform 1 alone; with the default ``boot_wait`` it never claims the master role."""
    config = CoreConfig(boot_wait=boot_wait, delivery_deadline=delivery_deadline)
    return Node(1, swarm=SWARM, config=config, now=0.0)


def data(dst: int, channel: int) -> Data:
    return Data(
        dst=dst, channel=channel, seq=1, floor=1, epoch=0, payload=AppMessage(topic="t", body=b"")
    )


def test_collector_numbers_in_production_order_and_lists_urgent_first() -> None:
    out = Collector(swarm=SWARM, sender=1)
    hb = Heartbeat(is_master=False, epoch=0, master=0)
    out.send(None, hb, NORMAL)  # 1
    out.queue(5, data(5, URGENT), URGENT)  # 2
    out.queue(6, data(6, NORMAL), NORMAL)  # 3
    out.send(7, hb, NORMAL)  # 4: numbered after what was queued before it
    out.queue(8, data(8, NORMAL), NORMAL)  # 5, when taken
    ready = out.take()
    assert numbered(ready.packets) == [
        ("Data", URGENT, 2),
        ("Heartbeat", NORMAL, 1),
        ("Data", NORMAL, 3),
        ("Heartbeat", NORMAL, 4),
        ("Data", NORMAL, 5),
    ]
    assert [o.dst for o in ready.packets] == [5, None, 6, 7, 8]


def test_node_lists_the_urgent_channel_first_then_in_order() -> None:
    node = lone_node()
    node.tick(0.5)  # a heartbeat, numbered before the messages below
    node.send_app(2, "slow", b"1", 0.5)
    node.send_app(3, "operator", b"2", 0.5, urgent=True)
    node.send_app(4, "slow", b"3", 0.5)
    got = numbered(node.ready().packets)
    assert got[0][:2] == ("Data", URGENT)
    rest = got[1:]
    assert [kind for kind, _, _ in rest] == ["Heartbeat", "Data", "Data"]
    assert all(channel == NORMAL for _, channel, _ in rest)
    seqs = [seq for _, _, seq in rest]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    assert got[0][2] == seqs[1] + 1, "the urgent message was numbered between the others"


def test_a_retransmission_queued_before_a_heartbeat_keeps_its_place() -> None:
    node = lone_node()
    node.send_app(2, "t", b"x", 0.0)
    (first,) = node.ready().packets
    first_body = decode(first.data, swarm=SWARM).body
    assert isinstance(first_body, Data)
    # At 1 s the stream's timer (due after retry_base) runs before the heartbeat is sent.
    node.tick(1.0)
    packets = node.ready().packets
    got = numbered(packets)
    assert [kind for kind, _, _ in got] == ["Data", "Heartbeat"]
    assert got[0][2] < got[1][2], "the retransmission is numbered before the heartbeat"
    again = decode(packets[0].data, swarm=SWARM).body
    assert isinstance(again, Data) and again.seq == first_body.seq, "a retransmission"


def test_ready_takes_everything_and_a_second_call_is_empty() -> None:
    node = lone_node()
    node.tick(0.5)
    node.send_app(2, "t", b"x", 0.5)
    node.send_app(None, "to-master", b"y", 0.5)  # no master: waits, sends nothing
    node.send_app(1, "self", b"z", 0.5)  # to itself: an event
    assert node.has_ready
    ready = node.ready()
    assert ready and len(ready.packets) == 2 and len(ready.events) == 1
    assert not node.has_ready
    again = node.ready()
    assert not again and again.packets == [] and again.events == []


def test_the_node_has_one_way_in_and_one_way_out() -> None:
    """Packets come in checked, through ``receive_packet`` (a pipeline's guard checked the
    bytes); everything leaves through ``ready()``: no second door either way."""
    node = lone_node()
    assert callable(node.receive_packet) and callable(node.ready)
    for second in ("receive", "receive_batch", "drain_outgoing", "drain_events"):
        assert not hasattr(node, second), second
    out = Collector(swarm=SWARM, sender=1)
    assert not hasattr(out, "take_packets") and not hasattr(out, "take_events")


def test_barrier_events_arrive_through_ready() -> None:
    node = lone_node(boot_wait=0.2)
    seen = []
    t = 0.0
    while not any(isinstance(e, BecameMaster) for e in seen):
        deadline = node.next_deadline()
        assert deadline is not None and deadline < 5.0, "a lone platform claims"
        t = deadline
        node.tick(t)
        seen += node.ready().events
    node.request_barrier(7, 1, t)
    events = node.ready().events
    fired = [e for e in events if isinstance(e, BarrierFired)]
    released = [e for e in events if isinstance(e, BarrierReleased)]
    assert [e.key for e in fired] == [7] and [e.key for e in released] == [7]
    assert events.index(fired[0]) < events.index(released[0])


def test_delivery_failures_arrive_through_ready() -> None:
    node = lone_node(delivery_deadline=1.0)
    node.send_app(2, "t", b"x", 0.0)
    node.ready()
    node.tick(0.5)
    assert not any(isinstance(e, DeliveryFailed) for e in node.ready().events)
    node.tick(1.5)
    failed = [e for e in node.ready().events if isinstance(e, DeliveryFailed)]
    assert [(e.dst, e.kind) for e in failed] == [(2, "AppMessage")]
    assert "not acknowledged" in failed[0].reason


def test_streams_and_board_share_one_collector() -> None:
    """What the board and the streams give up lands in the one collector, in order; their
    packets are numbered together, in the order they were made."""
    config = CoreConfig()
    out = Collector(swarm=SWARM, sender=1)
    reliable = Reliable(config, out)
    board = BulletinBoard(config, out)
    reliable.send(2, AppMessage(topic="s", body=b""), 0.0, 1)
    board.post(AppMessage(topic="b", body=b""), {2, 3}, 0.0, 1, config.retry_base)
    reliable.send(3, AppMessage(topic="s", body=b""), 0.0, 1)
    assert [kind for kind, _, _ in numbered(out.take().packets)] == ["Data", "Bulletin", "Data"]
    board.clear("stepped_down")
    reliable.drop_destination(3, 0.1)
    assert [(f.dst, f.reason) for f in out.failures] == [
        (2, "stepped_down"),
        (3, "stepped_down"),
        (3, "left"),
    ]
