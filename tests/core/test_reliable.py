"""Reliable streams: order, dedup, cumulative acks, retransmission, window, deadlines, retarget."""

from __future__ import annotations

import itertools

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.core.delivery.reliable import ANSWERS_FLOOR, Reliable
from actorswarm.core.ready import DeliveryFailure
from actorswarm.core.wire import (
    NORMAL,
    TO_MASTER,
    URGENT,
    Ack,
    AppMessage,
    Data,
    Payload,
    RoleClaim,
)

SENDER, RECEIVER = 1, 2
EPOCH = 1


def _on_data(
    r: Reliable, sender: int, incarnation: int, data: Data
) -> tuple[list[Payload], Ack | None]:
    """``Reliable.on_data`` without the per-message epochs (tested on their own below)."""
    delivered, ack = r.on_data(sender, incarnation, data)
    return [payload for _, payload in delivered], ack


def _msg(n: int) -> AppMessage:
    return AppMessage(topic="t", body=bytes([n]))


def _data(seq: int, floor: int = 1, n: int | None = None, channel: int = NORMAL) -> Data:
    return Data(
        dst=RECEIVER,
        channel=channel,
        seq=seq,
        floor=floor,
        epoch=EPOCH,
        payload=_msg(seq if n is None else n),
    )


def _sent(r: Reliable) -> list[tuple[int, Data]]:
    """Take the queued packets, keeping the Data packets."""
    out = [(dst, body) for dst, body, _ in r.output.queued if isinstance(body, Data)]
    r.output.queued.clear()
    return out


def _seqs(r: Reliable) -> list[int]:
    return [d.seq for _, d in _sent(r)]


def _run(r: Reliable, until: float) -> list[tuple[float, int]]:
    """Tick at every deadline up to ``until``; return (time, seq) of each transmission."""
    log: list[tuple[float, int]] = []
    while (t := r.next_deadline()) is not None and t <= until:
        r.tick(t)
        log.extend((t, d.seq) for _, d in _sent(r))
    return log


# --- receiving ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("arrivals", "delivered", "acks"),
    [
        ([1, 2, 3], [[1], [2], [3]], [1, 2, 3]),
        ([3, 2, 1], [[], [], [1, 2, 3]], [0, 0, 3]),
        ([2, 1, 3], [[], [1, 2], [3]], [0, 2, 3]),
        ([1, 3, 4, 2], [[1], [], [], [2, 3, 4]], [1, 1, 1, 4]),
        ([1, 1, 2, 1, 2], [[1], [], [2], [], []], [1, 1, 2, 2, 2]),
        ([2, 2, 1], [[], [], [1, 2]], [0, 0, 2]),
    ],
    ids=["in-order", "reversed", "swap", "hole", "duplicates", "duplicate-buffered"],
)
def test_in_order_delivery_with_buffering_and_dedup(
    arrivals: list[int], delivered: list[list[int]], acks: list[int]
) -> None:
    r = Reliable(CoreConfig())
    got: list[list[int]] = []
    got_acks: list[int] = []
    for seq in arrivals:
        payloads, ack = _on_data(r, SENDER, 0, _data(seq))
        got.append([p.body[0] for p in payloads if isinstance(p, AppMessage)])
        assert ack is not None, "every accepted Data packet is acknowledged (again)"
        assert (ack.dst, ack.dst_incarnation, ack.channel) == (SENDER, 0, NORMAL)
        got_acks.append(ack.seq)
    assert got == delivered, f"arrivals {arrivals}: delivered {got}, want {delivered}"
    assert got_acks == acks, f"arrivals {arrivals}: cumulative acks {got_acks}, want {acks}"


def test_channels_are_independent_streams() -> None:
    r = Reliable(CoreConfig())
    assert _on_data(r, SENDER, 0, _data(2, channel=URGENT))[0] == []
    delivered, ack = _on_data(r, SENDER, 0, _data(1, channel=NORMAL))
    assert delivered == [_msg(1)], "a hole on URGENT does not hold NORMAL back"
    assert ack is not None and ack.channel == NORMAL


def test_first_packet_starts_stream_at_its_floor() -> None:
    r = Reliable(CoreConfig())
    delivered, ack = _on_data(r, SENDER, 0, _data(5, floor=5))
    assert delivered == [_msg(5)], "a receiver that joins late does not wait for seq 1..4"
    assert ack is not None and ack.seq == 5


def test_floor_skips_abandoned_gap() -> None:
    r = Reliable(CoreConfig())
    _on_data(r, SENDER, 0, _data(1))
    assert _on_data(r, SENDER, 0, _data(4, floor=2))[0] == [], "seq 2 and 3 still awaited"
    delivered, _ = _on_data(r, SENDER, 0, _data(3, floor=3))
    assert delivered == [_msg(3), _msg(4)], "floor 3: seq 2 was abandoned, 3 and 4 follow"


def test_hole_below_floor_delivers_buffered_messages_at_once() -> None:
    r = Reliable(CoreConfig())
    assert _on_data(r, SENDER, 0, _data(2, floor=1))[0] == [], "seq 1 missing: 2 is buffered"
    delivered, ack = _on_data(r, SENDER, 0, _data(3, floor=2))  # the sender abandoned seq 1
    assert delivered == [_msg(2), _msg(3)], f"delivered {delivered}"
    assert ack is not None and ack.seq == 3


def test_new_sender_incarnation_resets_stream_older_ignored() -> None:
    r = Reliable(CoreConfig())
    for seq in (1, 2, 3):
        _on_data(r, SENDER, 4, _data(seq))
    delivered, ack = _on_data(r, SENDER, 5, _data(1, n=101))
    assert delivered == [_msg(101)], "a rebooted sender numbers from 1 again"
    assert ack is not None and (ack.seq, ack.dst_incarnation) == (1, 5)
    delivered, ack = _on_data(r, SENDER, 4, _data(4))
    assert (delivered, ack) == ([], None), "the old incarnation is neither delivered nor acked"
    delivered, _ = _on_data(r, SENDER, 5, _data(2, n=102))
    assert delivered == [_msg(102)]


def test_forget_sender_starts_fresh_stream() -> None:
    r = Reliable(CoreConfig())
    _on_data(r, SENDER, 0, _data(1))
    r.forget_sender(SENDER, 0)
    delivered, _ = _on_data(r, SENDER, 0, _data(1, n=42))
    assert delivered == [_msg(42)]


def test_forget_sender_keeps_the_stream_of_its_new_incarnation() -> None:
    """Campaign seed 402238: a rebooted sender's first message arrived before its heartbeat
    showed the reboot; forgetting its new stream then delivered the retransmission twice."""
    r = Reliable(CoreConfig())
    _on_data(r, SENDER, 0, _data(1))
    delivered, _ = _on_data(r, SENDER, 1, _data(1, n=7))
    assert delivered == [_msg(7)]
    r.forget_sender(SENDER, 0)  # the reboot out of incarnation 0 is noticed now
    delivered, ack = _on_data(r, SENDER, 1, _data(1, n=7))
    assert delivered == [], "the retransmission of an already delivered message"
    assert ack is not None and ack.seq == 1, "acknowledged again"


def test_far_ahead_packets_are_not_buffered() -> None:
    r = Reliable(CoreConfig(window=2))  # buffer bound 4 * window = 8 ahead
    _on_data(r, SENDER, 0, _data(10))  # 9 ahead of expected 1: dropped
    _on_data(r, SENDER, 0, _data(8))  # 7 ahead: buffered
    delivered: list[Payload] = []
    for seq in range(1, 8):
        delivered += _on_data(r, SENDER, 0, _data(seq))[0]
    assert delivered == [_msg(n) for n in range(1, 9)], "seq 10 was dropped, 8 was kept"


# --- sending: acks, retransmission, window, deadlines -------------------------------------


def test_send_transmits_data_with_floor_and_epoch() -> None:
    r = Reliable(CoreConfig())
    r.send(RECEIVER, _msg(1), 0.0, 7)
    r.send(RECEIVER, _msg(2), 0.0, 7)
    sent = _sent(r)
    assert [(dst, d.seq, d.floor, d.epoch, d.channel) for dst, d in sent] == [
        (RECEIVER, 1, 1, 7, NORMAL),
        (RECEIVER, 2, 1, 7, NORMAL),
    ]
    assert r.pending(RECEIVER) == 2


def test_cumulative_ack_removes_items() -> None:
    r = Reliable(CoreConfig())
    for n in range(1, 5):
        r.send(RECEIVER, _msg(n), 0.0, EPOCH)
    _sent(r)
    r.on_ack(RECEIVER, Ack(dst=SENDER, dst_incarnation=0, channel=NORMAL, seq=3), 0.01)
    assert r.pending(RECEIVER) == 1, "seq 1..3 acknowledged at once"
    log = _run(r, 1.0)
    assert {seq for _, seq in log} == {4}, f"only seq 4 is retransmitted, got {log}"
    r.on_ack(RECEIVER, Ack(dst=SENDER, dst_incarnation=0, channel=NORMAL, seq=2), 1.0)
    assert r.pending(RECEIVER) == 1, "an old ack changes nothing"
    r.on_ack(RECEIVER, Ack(dst=SENDER, dst_incarnation=0, channel=NORMAL, seq=4), 1.0)
    assert r.pending(RECEIVER) == 0
    assert _run(r, 20.0) == [], "nothing left to retransmit"
    assert r.output.failures == []


def test_ack_for_other_channel_or_destination_ignored() -> None:
    r = Reliable(CoreConfig())
    r.send(RECEIVER, _msg(1), 0.0, EPOCH)
    r.on_ack(RECEIVER, Ack(dst=SENDER, dst_incarnation=0, channel=URGENT, seq=1), 0.0)
    r.on_ack(3, Ack(dst=SENDER, dst_incarnation=0, channel=NORMAL, seq=1), 0.0)
    assert r.pending(RECEIVER) == 1


def _retransmission_times(config: CoreConfig, until: float) -> list[float]:
    r = Reliable(config)
    r.send(RECEIVER, _msg(1), 0.0, EPOCH)
    assert _seqs(r) == [1]
    return [0.0] + [t for t, seq in _run(r, until) if seq == 1]


def test_retransmission_backoff_grows_to_cap_and_fails_at_deadline() -> None:
    config = CoreConfig(delivery_deadline=5.0)
    times = _retransmission_times(config, 10.0)
    gaps = [b - a for a, b in itertools.pairwise(times)]
    assert gaps, "the unacknowledged message must be retransmitted"
    assert all(config.retry_base - 1e-9 <= g <= config.retry_cap + 1e-9 for g in gaps), gaps
    assert all(a <= b + 1e-9 for a, b in itertools.pairwise(gaps)), (
        f"retransmission gaps must not shrink: {gaps}"
    )
    assert gaps[-2] == pytest.approx(config.retry_cap), f"gaps reach the cap: {gaps}"
    assert times[-1] < 5.0, "nothing is sent at or after the deadline"


def test_on_a_shared_channel_retransmissions_wait_for_the_swarm_and_double() -> None:
    """With a channel time (the swarm's packets ahead of this one) the first wait is at
    least twice that (the acknowledgement queues too), and doubles up to four times it;
    with a channel time too short to matter the doubling starts from the usual first wait
    and stops at ``retry_cap``; without one the linear backoff alone applies."""
    config = CoreConfig(delivery_deadline=10.0)
    r = Reliable(config)
    r.channel_time = 0.08
    r.send(RECEIVER, _msg(1), 0.0, EPOCH)
    assert _seqs(r) == [1]
    times = [0.0] + [t for t, seq in _run(r, 9.9) if seq == 1]
    gaps = [round(b - a, 9) for a, b in itertools.pairwise(times)]
    assert gaps[:5] == [0.16, 0.32, 0.32, 0.32, 0.32], gaps
    assert times[-1] < 10.0, "nothing is sent at or after the deadline"
    r = Reliable(config)
    r.channel_time = 0.001  # a handful of platforms: doubling from retry_base
    r.send(RECEIVER, _msg(2), 9.9, EPOCH)
    assert _seqs(r) == [1]
    times = [9.9] + [t for t, seq in _run(r, 12.0) if seq == 1]
    gaps = [round(b - a, 9) for a, b in itertools.pairwise(times)]
    assert gaps[:6] == [0.03, 0.06, 0.12, 0.2, 0.2, 0.2], gaps
    r = Reliable(config)  # channel_time 0: the linear backoff alone
    r.send(RECEIVER, _msg(3), 12.0, EPOCH)
    assert _seqs(r) == [1]
    resent = [t for t, seq in _run(r, 12.2) if seq == 1]
    assert resent[0] == pytest.approx(12.0 + config.retry_base)
    assert resent[1] - resent[0] == pytest.approx(config.retry_delay(1))


def test_a_retransmission_few_must_answer_waits_for_their_channel_time_only() -> None:
    """A release or bulletin resent to the few members that have not acknowledged it waits
    for their share of the channel (at least ANSWERS_FLOOR packets' worth), not the whole
    swarm's."""
    r = Reliable(CoreConfig())
    r.channel_time, r.channel_size = 0.8, 1000  # 0.8 ms a packet
    assert r.retry_delay(1) == pytest.approx(3.2), "the whole swarm: four channel times"
    assert r.retry_delay(1, answers=1000) == pytest.approx(3.2)
    assert r.retry_delay(1, answers=500) == pytest.approx(1.6)
    assert r.retry_delay(0, answers=100) == pytest.approx(0.16)
    few = r.retry_delay(1, answers=3)
    assert few == r.retry_delay(1, answers=ANSWERS_FLOOR)
    # 16 packets take 12.8 ms, under retry_base: the usual doubling from 30 ms.
    assert few == pytest.approx(0.06)


def test_retransmission_times_follow_linear_backoff() -> None:
    config = CoreConfig(delivery_deadline=3.0)
    times = _retransmission_times(config, 2.9)
    expected = [0.0]
    k = 0
    while expected[-1] + config.retry_delay(k) < 2.9:
        expected.append(expected[-1] + config.retry_delay(k))
        k += 1
    assert times == pytest.approx(expected), f"sent at {times}, want {expected}"


@pytest.mark.parametrize(("window", "sends"), [(1, 3), (2, 5), (4, 4), (3, 10)])
def test_window_limits_in_flight_and_refills_on_ack(window: int, sends: int) -> None:
    r = Reliable(CoreConfig(window=window))
    for n in range(1, sends + 1):
        r.send(RECEIVER, _msg(n), 0.0, EPOCH)
    in_flight = _seqs(r)
    assert in_flight == list(range(1, min(window, sends) + 1)), f"window {window}: {in_flight}"
    log = _run(r, 0.5)
    assert {seq for _, seq in log} <= set(in_flight), "queued messages are not retransmitted"
    order = list(in_flight)
    acked = 0
    while acked < sends:
        acked += 1
        ack = Ack(dst=SENDER, dst_incarnation=0, channel=NORMAL, seq=acked)
        r.on_ack(RECEIVER, ack, 1.0)
        new = _sent(r)
        order += [d.seq for _, d in new]
        for _, d in new:
            assert d.floor == acked + 1, f"seq {d.seq} sent with floor {d.floor}"
        assert r.pending(RECEIVER) == sends - acked
    assert order == list(range(1, sends + 1)), f"every message sent once, in order: {order}"


def test_deadline_expiry_reports_failure_and_raises_floor() -> None:
    config = CoreConfig(delivery_deadline=1.0)
    sender, receiver = Reliable(config), Reliable(config)
    sender.send(RECEIVER, _msg(1), 0.0, EPOCH)  # lost on the radio, every time
    sender.send(RECEIVER, _msg(2), 0.5, EPOCH)
    first = [d for _, d in _sent(sender) if d.seq == 2]
    assert _on_data(receiver, SENDER, 0, first[0])[0] == [], "seq 2 waits for seq 1"
    _run(sender, 0.99)
    assert sender.output.failures == []
    sender.tick(1.0)
    assert sender.output.failures == [DeliveryFailure(RECEIVER, _msg(1))], sender.output.failures
    assert sender.pending(RECEIVER) == 1
    _sent(sender)
    next_at = sender.next_deadline()
    assert next_at is not None, "seq 2 is still retransmitted"
    sender.tick(next_at)
    retransmitted = [d for _, d in _sent(sender) if d.seq == 2]
    assert retransmitted and retransmitted[0].floor == 2, "the floor moved past the failure"
    delivered, ack = _on_data(receiver, SENDER, 0, retransmitted[0])
    assert delivered == [_msg(2)], "the receiver skips the abandoned seq 1"
    assert ack is not None and ack.seq == 2
    sender.send(RECEIVER, _msg(3), 1.2, EPOCH)
    (new,) = [d for _, d in _sent(sender) if d.seq == 3]
    assert new.floor == 2


def test_failure_of_queued_message_refills_window() -> None:
    config = CoreConfig(delivery_deadline=1.0, window=1)
    r = Reliable(config)
    r.send(RECEIVER, _msg(1), 0.0, EPOCH)
    r.send(RECEIVER, _msg(2), 0.5, EPOCH)
    assert _seqs(r) == [1]
    log = _run(r, 1.0)
    assert r.output.failures == [DeliveryFailure(RECEIVER, _msg(1))]
    assert (1.0, 2) in log, f"seq 2 goes out when seq 1 fails: {log}"


# --- master-bound streams -----------------------------------------------------------------


def test_master_bound_messages_wait_for_a_master_then_go_in_order() -> None:
    r = Reliable(CoreConfig())
    assert r.master is None
    for n in (1, 2, 3):
        r.send_to_master(_msg(n), 0.1 * n, EPOCH)
    assert _sent(r) == [], "nothing is sent while there is no master"
    r.retarget(5, 0.5)
    sent = _sent(r)
    assert [(dst, d.channel, d.payload) for dst, d in sent] == [
        (5, TO_MASTER, _msg(1)),
        (5, TO_MASTER, _msg(2)),
        (5, TO_MASTER, _msg(3)),
    ], sent
    assert [d.seq for _, d in sent] == [1, 2, 3]
    # Epochs are stamped when queued: a new master tells stale requests apart (the member's
    # handshake report states what is still pending).
    assert all(d.epoch == EPOCH for _, d in sent), "stamped with the epoch they were queued in"
    assert r.master == 5


def test_hurrying_sends_what_the_master_lacks_again_without_moving_the_retries() -> None:
    r = Reliable(CoreConfig(retry_base=1.0, retry_cap=1.0))
    assert r.hurry_master(0.0, 0.2) == 0, "no master: nothing to send"
    r.retarget(5, 0.0)
    for n in (1, 2):
        r.send_to_master(_msg(n), 0.0, EPOCH)
    _sent(r)
    r.on_ack(5, Ack(dst=SENDER, dst_incarnation=0, channel=TO_MASTER, seq=1), 0.05)
    assert r.hurry_master(0.1, 0.2) == 0, "the copy went out 0.1 s ago, under the spacing"
    assert r.hurry_master(0.3, 0.2) == 1
    assert [(dst, d.seq) for dst, d in _sent(r)] == [(5, 2)], "only what is unacknowledged"
    assert r.hurry_master(0.4, 0.2) == 0, "spaced from the hurried copy too"
    # The retry schedule stands: the first retry 1 s after the first transmission.
    assert _run(r, 1.5) == [(1.0, 2)]


def test_copies_of_a_master_bound_message_go_out_at_once_and_count_as_one() -> None:
    r = Reliable(CoreConfig(retry_base=1.0, retry_cap=1.0))
    r.send_to_master(_msg(1), 0.0, EPOCH, copies=3)
    assert _sent(r) == [], "no master: the message waits, copies and all"
    r.retarget(5, 0.0)
    assert [(dst, d.seq) for dst, d in _sent(r)] == [(5, 1)], "moved once to the new master"
    seq = r.send_to_master(_msg(2), 0.1, EPOCH, copies=3)
    assert [(dst, d.seq) for dst, d in _sent(r)] == [(5, seq)] * 3
    r.on_ack(5, Ack(dst=SENDER, dst_incarnation=0, channel=TO_MASTER, seq=seq), 0.2)
    assert not r.master_holds(seq) and _run(r, 3.0) == [], "one acknowledgement settles all"


def test_retarget_moves_unacked_in_order_to_new_master() -> None:
    r = Reliable(CoreConfig())
    r.retarget(5, 0.0)
    for n in (1, 2, 3):
        r.send_to_master(_msg(n), 0.0, EPOCH)
    _sent(r)
    r.on_ack(5, Ack(dst=SENDER, dst_incarnation=0, channel=TO_MASTER, seq=1), 0.0)
    r.retarget(6, 0.1)
    assert [(dst, d.payload) for dst, d in _sent(r)] == [(6, _msg(2)), (6, _msg(3))]
    r.on_ack(5, Ack(dst=SENDER, dst_incarnation=0, channel=TO_MASTER, seq=3), 0.1)
    log = _run(r, 0.2)
    assert {seq for _, seq in log} == {2, 3}, "the old master's ack no longer counts"


def test_retarget_to_a_newer_epoch_drops_only_the_stale_kinds_of_that_older_epoch() -> None:
    # A new master ignores barrier and role traffic of an older epoch (the member's report
    # restates it): dropped at once, it does not hold up the stream's order; app messages
    # are delivered whatever their epoch, so they stay.
    r = Reliable(CoreConfig())
    r.retarget(5, 0.0)
    old = RoleClaim(role="leader", quota=1, bid=1.0)
    r.send_to_master(old, 0.0, EPOCH)
    r.send_to_master(_msg(1), 0.0, EPOCH)
    r.send_to_master(_msg(2), 0.0, EPOCH + 1)
    _sent(r)
    r.retarget(6, 0.1, EPOCH + 1, (RoleClaim,))
    assert [(dst, d.payload, d.epoch) for dst, d in _sent(r)] == [
        (6, _msg(1), EPOCH),
        (6, _msg(2), EPOCH + 1),
    ]


def test_retarget_never_delivers_twice_to_same_master() -> None:
    config = CoreConfig()
    member, master = Reliable(config), Reliable(config)
    member.retarget(5, 0.0)
    member.send_to_master(_msg(1), 0.0, EPOCH)
    (first,) = _sent(member)
    assert _on_data(master, SENDER, 0, first[1])[0] == [_msg(1)]  # its ack is lost
    member.retarget(None, 0.1)
    member.retarget(5, 0.2)
    member.retarget(5, 0.3)
    resent = _sent(member)
    assert len(resent) == 1, f"sent once on the way back to the master: {resent}"
    delivered, ack = _on_data(master, SENDER, 0, resent[0][1])
    assert delivered == [], "the master recognises the re-sent copy"
    assert ack is not None and ack.seq == 1


def test_drop_destination_of_master_keeps_master_bound_waiting() -> None:
    r = Reliable(CoreConfig())
    r.retarget(5, 0.0)
    r.send(5, _msg(10), 0.0, 1)  # a direct message to the master's platform
    r.send_to_master(_msg(1), 0.0, EPOCH)
    r.send_to_master(_msg(2), 0.0, EPOCH)
    _sent(r)
    r.drop_destination(5, 0.1)
    assert r.master is None
    assert r.pending(5) == 0, "the direct queue to a member that left is dropped"
    assert _run(r, 1.0) == [], "nothing is retransmitted while there is no master"
    r.retarget(7, 1.0)
    assert [(dst, d.payload) for dst, d in _sent(r)] == [(7, _msg(1)), (7, _msg(2))]
    # The direct message is reported as given up (its destination left); the master-bound
    # ones are not: they went to the next master.
    assert [(f.dst, f.payload, f.reason) for f in r.output.failures] == [(5, _msg(10), "left")]


def test_take_unrouted_hands_over_in_order() -> None:
    r = Reliable(CoreConfig())
    r.retarget(5, 0.0)
    r.send_to_master(_msg(1), 0.0, EPOCH)
    r.send_to_master(_msg(2), 0.0, EPOCH)
    _sent(r)
    r.drop_destination(5, 0.1)
    r.send_to_master(_msg(3), 0.2, 1)
    assert r.take_unrouted() == [_msg(1), _msg(2), _msg(3)]
    assert r.take_unrouted() == []
    r.retarget(6, 0.3)
    assert _sent(r) == []


def test_drop_destination_keeps_numbering() -> None:
    r = Reliable(CoreConfig())
    r.send(RECEIVER, _msg(1), 0.0, EPOCH)
    r.send(RECEIVER, _msg(2), 0.0, EPOCH)
    _sent(r)
    r.drop_destination(RECEIVER, 0.1)
    r.send(RECEIVER, _msg(3), 0.2, EPOCH)
    ((_, data),) = _sent(r)
    assert (data.seq, data.floor) == (3, 3), "a returning peer never sees a reused number"


def test_master_bound_message_without_master_fails_at_deadline() -> None:
    r = Reliable(CoreConfig(delivery_deadline=2.0))
    r.send_to_master(_msg(1), 0.0, EPOCH)
    assert r.next_deadline() == pytest.approx(2.0)
    r.tick(1.99)
    assert r.output.failures == []
    r.tick(2.0)
    assert r.output.failures == [DeliveryFailure(None, _msg(1))], (
        "dst None: it never found a master"
    )
    assert r.take_unrouted() == []


def test_retarget_keeps_original_deadline() -> None:
    r = Reliable(CoreConfig(delivery_deadline=2.0))
    r.send_to_master(_msg(1), 0.0, EPOCH)
    r.retarget(5, 1.5)
    _run(r, 2.0)
    assert r.output.failures == [DeliveryFailure(5, _msg(1))], "moving does not extend the deadline"


def test_buffered_messages_keep_the_epoch_they_were_sent_in() -> None:
    r = Reliable(CoreConfig())
    early = Data(dst=RECEIVER, channel=NORMAL, seq=2, floor=1, epoch=7, payload=_msg(2))
    late = Data(dst=RECEIVER, channel=NORMAL, seq=1, floor=1, epoch=8, payload=_msg(1))
    assert r.on_data(SENDER, 0, early)[0] == []
    delivered, _ = r.on_data(SENDER, 0, late)
    assert delivered == [(8, _msg(1)), (7, _msg(2))], "each message keeps its own epoch"
