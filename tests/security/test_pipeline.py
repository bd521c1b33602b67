"""The pipeline is an endpoint's one way in and one way out: bytes reach the endpoint only
once its guard passed them, and what the endpoint gives up through ``ready()`` is sealed and
sent — once per batch, or after every packet (``flush_each``)."""

from __future__ import annotations

from actorswarm.core.node import Outgoing, Ready
from actorswarm.core.wire import NORMAL, URGENT, Heartbeat, Packet, encode
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline, Traffic

SWARM = "pipe"


def _heartbeat(sender: int, seq: int) -> bytes:
    body = Heartbeat(is_master=False, epoch=0, master=0)
    return encode(swarm=SWARM, sender=sender, incarnation=0, seq=seq, body=body)


class _Wire:
    def __init__(self) -> None:
        self.sent: list[tuple[int | None, bytes, bool, str]] = []

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        self.sent.append((dst, data, urgent, kind))


class _Echo:
    """Answers every packet with one of its own; notes how many packets the wire had carried
    when each packet came in."""

    def __init__(self, wire: _Wire) -> None:
        self.wire = wire
        self.out: list[Outgoing] = []
        self.seen: list[tuple[int, int]] = []

    def receive_packet(self, packet: Packet, now: float) -> None:
        self.seen.append((packet.seq, len(self.wire.sent)))
        self.out.append(Outgoing(None, _heartbeat(9, packet.seq), "Heartbeat", NORMAL))

    def ready(self) -> Ready:
        out, self.out = self.out, []
        return Ready(out)


def test_bytes_reach_the_endpoint_only_past_the_guard() -> None:
    wire = _Wire()
    endpoint = _Echo(wire)
    pipeline = Pipeline(endpoint, wire, PacketGuard.insecure())
    assert pipeline.receive(_heartbeat(2, 1), 0.0)
    assert not pipeline.receive(b"\x00not a packet", 0.0)
    assert pipeline.receive_all([b"junk", _heartbeat(2, 2)], 0.1) == 1
    assert [seq for seq, _ in endpoint.seen] == [1, 2]
    assert pipeline.guard.rejected["malformed"] == 2


def test_a_batch_is_sent_once_after_it_or_after_every_packet() -> None:
    """Without ``flush_each`` the endpoint's answers wait for the host's flush; with it each
    answer is on the wire before the next packet comes in. Either way they leave in the
    order the endpoint made them, counted."""
    batch = [_heartbeat(2, seq) for seq in (1, 2, 3)]
    for each, wire_before in ((False, [0, 0, 0]), (True, [0, 1, 2])):
        wire, traffic = _Wire(), Traffic()
        endpoint = _Echo(wire)
        pipeline = Pipeline(endpoint, wire, PacketGuard.insecure(), traffic)
        assert pipeline.receive_all(batch, 0.0, flush_each=each) == 3
        assert [n for _, n in endpoint.seen] == wire_before
        pipeline.flush()
        answers = [data for _, data, _, _ in wire.sent]
        assert answers == [_heartbeat(9, seq) for seq in (1, 2, 3)]
        assert traffic.sent_packets == 3 and traffic.recv_packets == 3


def test_flush_sends_what_ready_gives_and_nothing_twice() -> None:
    wire = _Wire()
    endpoint = _Echo(wire)
    pipeline = Pipeline(endpoint, wire, PacketGuard.insecure())
    endpoint.out.append(Outgoing(4, _heartbeat(9, 7), "Ack", URGENT))
    assert pipeline.flush() == 1
    assert wire.sent == [(4, _heartbeat(9, 7), True, "Ack")]
    assert pipeline.flush() == 0
