"""Bulletins: one broadcast from the master to every member, resent only to the missing.

Tested on their own (:class:`BulletinBoard` and :class:`BulletinInbox` exchanging packets
by hand, some lost), then on a simulated swarm: the master's relay of a message to 30
members is one packet, not 29, and every member gets it exactly once, in order, under loss.
"""

from __future__ import annotations

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.core.delivery.bulletin import UNICAST_AT_MOST, BulletinBoard, BulletinInbox
from actorswarm.core.events import AppReceived, DeliveryFailed
from actorswarm.core.ready import Ready
from actorswarm.core.wire import AppMessage, Bulletin, BulletinAck, decode, encode
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.swarm import SimSwarm

CONFIG = CoreConfig()
MASTER = 1
RETRY = 0.05


def msg(text: str) -> AppMessage:
    return AppMessage(topic="t", body=text.encode())


def board_with(*texts: str, targets: set[int], skip: tuple[int, ...] = ()) -> BulletinBoard:
    board = BulletinBoard(CONFIG)
    for text in texts:
        board.post(msg(text), targets, 0.0, 1, RETRY, skip=skip)
    return board


def take(board: BulletinBoard) -> list[tuple[int | None, Bulletin]]:
    """Take the bulletins the board queued in its collector: (destination, bulletin)."""
    queued, board.output.queued = board.output.queued, []
    out = [(dst, body) for dst, body, _ in queued if isinstance(body, Bulletin)]
    assert len(out) == len(queued), "a board queues bulletins only"
    return out


def inbox(platform: int) -> BulletinInbox:
    box = BulletinInbox(platform)
    box.follow(MASTER)
    return box


def deliver(box: BulletinInbox, bulletin: Bulletin) -> tuple[list[str], BulletinAck | None]:
    got, ack = box.on_bulletin(MASTER, 0, bulletin)
    return [b.message.body.decode() for b in got], ack


def test_one_broadcast_per_post_and_acks_end_it() -> None:
    board = board_with("a", "b", targets={2, 3})
    out = take(board)
    assert [(dst, b.seq) for dst, b in out] == [(None, 1), (None, 2)]
    boxes = {p: inbox(p) for p in (2, 3)}
    for p, box in boxes.items():
        texts: list[str] = []
        for _, bulletin in out:
            got, ack = deliver(box, bulletin)
            texts += got
            assert ack is not None
            board.on_ack(p, ack)
        assert texts == ["a", "b"]
    assert not board.posted
    board.tick(10.0, 1, RETRY)
    assert take(board) == [] and board.output.failures == []


def test_a_lost_bulletin_is_resent_to_the_missing_member_only() -> None:
    board = board_with("a", targets={2, 3, 4})
    ((_, first),) = take(board)
    for p in (2, 3):
        _, ack = deliver(inbox(p), first)
        assert ack is not None
        board.on_ack(p, ack)
    board.tick(1.0, 1, RETRY)
    out = take(board)
    assert [(dst, b.to) for dst, b in out] == [(4, [4])]
    got, ack = deliver(inbox(4), out[0][1])
    assert got == ["a"] and ack is not None and ack.seq == 1


def test_many_missing_get_one_broadcast_naming_them_in_chunks() -> None:
    config = CoreConfig(release_chunk=10)
    board = BulletinBoard(config)
    targets = set(range(2, 2 + 25))
    board.post(msg("a"), targets, 0.0, 1, RETRY)
    take(board)
    board.tick(1.0, 1, RETRY)
    assert len(targets) > UNICAST_AT_MOST
    out = take(board)
    assert [dst for dst, _ in out] == [None, None, None]
    named = [p for _, b in out for p in b.to or []]
    assert sorted(named) == sorted(targets)


def test_a_duplicate_is_acknowledged_not_delivered() -> None:
    board = board_with("a", targets={2})
    box = inbox(2)
    bulletin = take(board)[0][1]
    assert deliver(box, bulletin)[0] == ["a"]
    again, ack = deliver(box, bulletin)
    assert again == [] and ack is not None and ack.seq == 1


def test_order_is_kept_across_a_gap() -> None:
    board = board_with("a", "b", "c", targets={2})
    box = inbox(2)
    first, second, third = (b for _, b in take(board))
    assert deliver(box, first)[0] == ["a"]
    assert deliver(box, third)[0] == []  # waits for the second
    assert deliver(box, second)[0] == ["b", "c"]


def test_the_origin_named_in_skip_gets_nothing_but_keeps_its_place() -> None:
    board = board_with("event", targets={2, 3}, skip=(2,))
    board.post(msg("next"), {2, 3}, 0.0, 1, RETRY)
    box = inbox(2)
    got = [t for _, b in take(board) for t in deliver(box, b)[0]]
    assert got == ["next"]
    assert board.posted[1].unacked == {3}  # the origin is not waited for


def test_a_retransmission_naming_others_fills_no_gap() -> None:
    """Platform 5's name may be in another chunk of the same retransmission: a chunk that
    names others says nothing about it, so it must not skip the bulletin."""
    box = inbox(5)
    box.on_bulletin(MASTER, 0, Bulletin(epoch=1, seq=1, floor=1, message=msg("a")))
    other = Bulletin(epoch=1, seq=2, floor=1, message=msg("b"), to=[3, 4])
    assert deliver(box, other)[0] == []
    mine = Bulletin(epoch=1, seq=2, floor=1, message=msg("b"), to=[5])
    assert deliver(box, mine)[0] == ["b"]


def test_a_member_that_was_no_target_skips_at_the_floor() -> None:
    """A platform that joined after bulletin 2 was posted never gets it resent; the floor
    of a later bulletin lets it go on."""
    box = inbox(9)
    assert deliver(box, Bulletin(epoch=1, seq=1, floor=1, message=msg("a")))[0] == ["a"]
    assert deliver(box, Bulletin(epoch=1, seq=3, floor=2, message=msg("c")))[0] == []
    assert deliver(box, Bulletin(epoch=1, seq=4, floor=3, message=msg("d")))[0] == ["c", "d"]


def test_the_handshake_says_where_a_joiner_begins() -> None:
    """A joiner that first hears bulletin 50 while bulletin 1 is still held for someone else
    would wait for it; the master's Sync (first bulletin of its own: 50) frees it at once."""
    box = inbox(9)
    assert deliver(box, Bulletin(epoch=1, seq=50, floor=1, message=msg("x")))[0] == []
    assert [b.message.body for b in box.start(50)] == [b"x"]
    # Heard after the Sync, a bulletin starts the stream at the Sync's number.
    late = inbox(9)
    assert late.start(50) == []
    assert deliver(late, Bulletin(epoch=1, seq=51, floor=1, message=msg("y")))[0] == []
    assert deliver(late, Bulletin(epoch=1, seq=50, floor=1, message=msg("x")))[0] == ["x", "y"]


def test_only_the_followed_master_is_heard_and_a_reboot_starts_afresh() -> None:
    box = inbox(2)
    bulletin = Bulletin(epoch=1, seq=7, floor=7, message=msg("a"))
    assert box.on_bulletin(3, 0, bulletin) == ([], None)
    assert deliver(box, bulletin)[0] == ["a"]
    rebooted = Bulletin(epoch=1, seq=1, floor=1, message=msg("b"))
    got, ack = box.on_bulletin(MASTER, 1, rebooted)
    assert [b.message.body for b in got] == [b"b"]
    assert ack is not None and ack.dst_incarnation == 1
    assert box.on_bulletin(MASTER, 0, bulletin) == ([], None)  # the old incarnation
    box.follow(None)
    assert box.on_bulletin(MASTER, 1, rebooted) == ([], None)


def test_malformed_floor_is_ignored() -> None:
    box = inbox(2)
    bad = Bulletin(epoch=1, seq=3, floor=9, message=msg("a"))
    assert box.on_bulletin(MASTER, 0, bad) == ([], None)


def test_deadline_and_leaving_members() -> None:
    board = board_with("a", targets={2, 3, 4})
    board.member_left(4)
    board.tick(CONFIG.delivery_deadline + 1.0, 1, RETRY)
    assert sorted(f.dst for f in board.output.failures if f.dst is not None) == [2, 3]
    assert not board.posted
    board = board_with("a", targets={2})
    board.clear("stepped_down")
    assert [(f.dst, f.reason) for f in board.output.failures] == [(2, "stepped_down")]


def _relay_swarm(loss: float, seed: int) -> SimSwarm:
    swarm = SimSwarm(31, seed=seed, link=LinkModel(latency=0.005, loss=loss))
    swarm.run_until(3.0)
    assert swarm.current_masters() == [1] and swarm.formed(31), "setup: formed"
    return swarm


@pytest.mark.parametrize(("loss", "seed"), [(0.0, 1), (0.3, 2), (0.3, 3)])
def test_a_swarm_gets_each_bulletin_once_in_order(loss: float, seed: int) -> None:
    swarm = _relay_swarm(loss, seed)
    master = swarm.node(1)
    sent: list[tuple[int | None, str]] = []
    ready = master.ready

    def recording() -> Ready:
        out = ready()
        sent.extend((o.dst, o.kind) for o in out.packets)
        return out

    master.ready = recording  # type: ignore[method-assign]
    for i in range(5):
        swarm.at(3.1 + 0.01 * i, lambda n=i: master.post_bulletin("news", bytes([n]), swarm.now))
    swarm.run_until(8.0)
    got: dict[int, list[bytes]] = {p: [] for p in range(2, 32)}
    for entry in swarm.log:
        if isinstance(entry.event, AppReceived) and entry.event.topic == "news":
            got[entry.platform].append(entry.event.body)
    expected = [bytes([i]) for i in range(5)]
    assert all(v == expected for v in got.values()), {p: v for p, v in got.items() if v != expected}
    packets = [s for s in sent if s[1] == "Bulletin"]
    if loss == 0.0:
        assert packets == [(None, "Bulletin")] * 5  # five posts, five packets: not 5 x 30
    else:
        assert len(packets) < 5 * 30 / 2, f"{len(packets)} bulletin packets for 150 deliveries"
    failed = [e for e in swarm.log if isinstance(e.event, DeliveryFailed) and e.platform == 1]
    assert failed == []
    assert swarm.finish() == []  # nothing delivered twice, among the rest


def test_a_bulletin_on_the_wire_round_trips() -> None:
    board = board_with("a", targets={2})
    bulletin = take(board)[0][1]
    data = encode(swarm="s", sender=1, incarnation=0, seq=1, body=bulletin)
    assert decode(data).body == bulletin
