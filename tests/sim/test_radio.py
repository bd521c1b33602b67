"""The simulated radio: delivery, faults, partitions, crashes, counters, determinism."""

from __future__ import annotations

import random
from collections.abc import Callable
from typing import Any

import pytest

from actorswarm.core import wire
from actorswarm.sim.radio import GilbertElliott, LinkModel, SimRadio, Transmission
from actorswarm.sim.scheduler import Scheduler

# (delivery time, receiver, sender, bytes, corrupted)
Log = list[tuple[float, int, int, bytes, bool]]


def _identity(data: bytes) -> bytes:
    return data


def make(
    model: LinkModel,
    *,
    platforms: int = 5,
    seed: int = 1,
    decoder: Callable[[bytes], bytes] = _identity,
) -> tuple[Scheduler, SimRadio[bytes], Log]:
    sched = Scheduler()
    radio = SimRadio(sched, random.Random(seed), model, decoder=decoder)
    log: Log = []
    for p in range(1, platforms + 1):
        attach_logger(radio, p, log)
    return sched, radio, log


def attach_logger(radio: SimRadio[bytes], platform: int, log: Log) -> None:
    def deliver(tx: Transmission[bytes], now: float) -> None:
        log.append((now, platform, tx.src, tx.data, tx.corrupted))

    radio.attach(platform, deliver)


def seq_bytes(i: int) -> bytes:
    return i.to_bytes(4, "big")


# --- configuration ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"loss": 1.5}, r"LinkModel\.loss must be a probability"),
        ({"loss": -0.1}, r"LinkModel\.loss"),
        ({"duplicate": float("nan")}, r"LinkModel\.duplicate"),
        ({"latency": -1.0}, r"LinkModel\.latency must be a finite number of seconds"),
        ({"jitter": float("inf")}, r"LinkModel\.jitter"),
        ({"reorder_delay": -0.5}, r"LinkModel\.reorder_delay"),
        ({"bandwidth": 0.0}, r"LinkModel\.bandwidth"),
        ({"corrupt": 2.0}, r"LinkModel\.corrupt"),
    ],
)
def test_link_model_validation(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        LinkModel(**kwargs)


def test_gilbert_elliott_validation_and_mean_loss() -> None:
    with pytest.raises(ValueError, match=r"GilbertElliott\.p_bad_to_good"):
        GilbertElliott(p_good_to_bad=0.1, p_bad_to_good=1.1)
    ge = GilbertElliott(p_good_to_bad=0.05, p_bad_to_good=0.2)
    assert ge.mean_loss == pytest.approx(0.2)
    assert LinkModel().faultless
    assert not LinkModel(burst=ge).faultless


# --- basic delivery -----------------------------------------------------------------------


def test_unicast_arrives_after_latency() -> None:
    sched, radio, log = make(LinkModel(latency=0.02))
    sched.run_until(1.0)
    radio.send(1, 2, b"hello", "test")
    sched.run_until(2.0)
    assert [entry[1:] for entry in log] == [(2, 1, b"hello", False)]
    assert log[0][0] == pytest.approx(1.02)


def test_broadcast_reaches_everyone_but_the_sender_in_one_event() -> None:
    sched, radio, log = make(LinkModel(), platforms=10)
    radio.send(4, None, b"hb", "heartbeat")
    assert sched.pending == 1  # one event for nine receivers
    sched.run_until(1.0)
    assert [entry[1] for entry in log] == [1, 2, 3, 5, 6, 7, 8, 9, 10]
    assert all(entry[0] == pytest.approx(0.01) for entry in log)


def test_broadcast_with_jitter_is_delivered_in_time_order() -> None:
    sched, radio, log = make(LinkModel(jitter=0.005), platforms=10)
    radio.send(1, None, b"hb", "heartbeat")
    assert sched.pending == 1  # a chain of events, one in the heap at a time
    sched.run_until(1.0)
    assert sorted(entry[1] for entry in log) == list(range(2, 11))
    times = [entry[0] for entry in log]
    assert times == sorted(times)
    assert all(0.01 <= t <= 0.015 for t in times)


def test_send_to_self_is_refused() -> None:
    _, radio, _ = make(LinkModel())
    with pytest.raises(ValueError, match="itself"):
        radio.send(1, 1, b"x", "test")


def test_attach_twice_is_refused_and_detach_reports() -> None:
    _, radio, _ = make(LinkModel(), platforms=2)
    with pytest.raises(ValueError, match="already attached"):
        radio.attach(1, lambda tx, now: None)
    assert set(radio.attached) == {1, 2}
    assert radio.detach(2) is True
    assert radio.detach(2) is False
    assert set(radio.attached) == {1}


def test_tap_sees_every_send() -> None:
    sched, radio, _ = make(LinkModel(), platforms=3)
    taps: list[tuple[float, int, int | None, str, int]] = []
    radio.tap = lambda now, src, dst, kind, size: taps.append((now, src, dst, kind, size))
    radio.send(1, None, b"abc", "heartbeat")
    sched.run_until(0.5)
    radio.send(2, 3, b"abcd", "data")
    assert taps == [(0.0, 1, None, "heartbeat", 3), (0.5, 2, 3, "data", 4)]


# --- determinism --------------------------------------------------------------------------

FAULTY = LinkModel(
    loss=0.1,
    latency=0.01,
    jitter=0.004,
    duplicate=0.1,
    reorder=0.2,
    reorder_delay=0.03,
    burst=GilbertElliott(p_good_to_bad=0.05, p_bad_to_good=0.3),
    corrupt=0.05,
)


def run_traffic(seed: int, model: LinkModel = FAULTY) -> tuple[Log, dict[str, int]]:
    sched, radio, log = make(model, platforms=6, seed=seed)
    for step in range(200):
        t = step * 0.002
        sched.run_until(t)
        src = 1 + step % 6
        dst = 1 + (src + step) % 6
        if step % 3 == 0 or dst == src:
            radio.send(src, None, seq_bytes(step), "heartbeat")
        else:
            radio.send(src, dst, seq_bytes(step), "data")
    sched.run_until(10.0)
    return log, dict(radio.drops)


def test_same_seed_same_run() -> None:
    first = run_traffic(7)
    assert first == run_traffic(7)
    assert first[0]  # something was delivered
    assert sum(first[1].values()) > 0  # and something was lost


def test_different_seed_different_run() -> None:
    assert run_traffic(7)[0] != run_traffic(8)[0]


# --- faults -------------------------------------------------------------------------------


def test_loss_rate_matches_the_model() -> None:
    sched, radio, log = make(LinkModel(loss=0.2), platforms=2, seed=3)
    n = 10_000
    for _ in range(n):
        radio.send(1, 2, b"x", "data")
    sched.run_until(1.0)
    delivered = len(log) / n
    assert delivered == pytest.approx(0.8, abs=0.02)
    assert radio.drops["loss"] == n - len(log)


def _mean_loss_run(model: LinkModel, n: int = 10_000) -> tuple[float, float]:
    """(loss rate, mean length of a run of consecutive losses) on one directed link."""
    sched, radio, log = make(model, platforms=2, seed=11)
    for i in range(n):
        sched.run_until(i * 0.001)
        radio.send(1, 2, seq_bytes(i), "data")
    sched.run_until(n * 0.001 + 1.0)
    received = {int.from_bytes(entry[3], "big") for entry in log}
    runs: list[int] = []
    current = 0
    for i in range(n):
        if i in received:
            if current:
                runs.append(current)
            current = 0
        else:
            current += 1
    if current:
        runs.append(current)
    return (n - len(received)) / n, sum(runs) / len(runs)


def test_gilbert_elliott_loss_is_burstier_than_independent_loss() -> None:
    burst = GilbertElliott(p_good_to_bad=0.05, p_bad_to_good=0.2)
    rate_ind, run_ind = _mean_loss_run(LinkModel(loss=burst.mean_loss))
    rate_ge, run_ge = _mean_loss_run(LinkModel(burst=burst))
    assert rate_ind == pytest.approx(0.2, abs=0.03)
    assert rate_ge == pytest.approx(0.2, abs=0.05)
    assert run_ind < 1.5  # about 1 / (1 - 0.2)
    assert run_ge > 3.0  # about 1 / p_bad_to_good = 5


def test_gilbert_elliott_state_is_per_directed_link() -> None:
    # Always-bad after the first packet on a link, total loss when bad: every link loses all
    # its packets, but the first packet on each link fresh from the good state is delivered.
    model = LinkModel(burst=GilbertElliott(p_good_to_bad=1.0, p_bad_to_good=0.0, loss_good=0.0))
    sched, radio, log = make(model, platforms=3)
    radio.send(1, 2, b"a", "data")  # link 1->2 steps to bad: lost
    radio.send(2, 1, b"b", "data")  # link 2->1 steps to bad: lost
    sched.run_until(1.0)
    assert log == []
    assert radio.drops["burst"] == 2
    relaxed = GilbertElliott(p_good_to_bad=0.0, p_bad_to_good=1.0)
    radio.model = LinkModel(burst=relaxed)
    radio.send(1, 2, b"c", "data")  # bad -> good, delivered
    radio.send(1, 3, b"d", "data")  # new link, stays good
    sched.run_until(2.0)
    assert [entry[3] for entry in log] == [b"c", b"d"]


def test_duplication_delivers_copies() -> None:
    sched, radio, log = make(LinkModel(duplicate=1.0, reorder_delay=0.02), platforms=3)
    radio.send(1, 2, b"u", "data")
    radio.send(1, None, b"b", "heartbeat")
    sched.run_until(1.0)
    assert sorted((entry[1], entry[3]) for entry in log) == [
        (2, b"b"),
        (2, b"b"),
        (2, b"u"),
        (2, b"u"),
        (3, b"b"),
        (3, b"b"),
    ]
    assert all(0.01 <= entry[0] <= 0.03 for entry in log)
    assert radio.traffic.totals(2)[2] == 4
    assert radio.traffic.totals(1)[0] == 2


def test_reordering_changes_the_order() -> None:
    sched, radio, log = make(LinkModel(reorder=0.3, reorder_delay=0.05), platforms=2)
    for i in range(200):
        sched.run_until(i * 0.001)
        radio.send(1, 2, seq_bytes(i), "data")
    sched.run_until(5.0)
    order = [int.from_bytes(entry[3], "big") for entry in log]
    assert sorted(order) == list(range(200))  # nothing lost, nothing duplicated
    assert order != list(range(200))


def test_no_reordering_without_faults() -> None:
    sched, radio, log = make(LinkModel(), platforms=2)
    for i in range(50):
        sched.run_until(i * 0.001)
        radio.send(1, 2, seq_bytes(i), "data")
    sched.run_until(5.0)
    assert [int.from_bytes(entry[3], "big") for entry in log] == list(range(50))


def test_bandwidth_delays_a_burst() -> None:
    n, size, bandwidth, latency = 10, 1000, 10_000.0, 0.01
    sched, radio, log = make(LinkModel(latency=latency, bandwidth=bandwidth), platforms=3)
    for i in range(n):
        radio.send(1, 2, seq_bytes(i) + bytes(size - 4), "data")
    radio.send(3, 2, b"other transmitter", "data")
    sched.run_until(5.0)
    from_1 = [entry[0] for entry in log if entry[2] == 1]
    assert from_1[0] == pytest.approx(size / bandwidth + latency)
    assert from_1[-1] == pytest.approx(n * size / bandwidth + latency)
    from_3 = [entry[0] for entry in log if entry[2] == 3]
    assert from_3 == [pytest.approx(17 / bandwidth + latency)]
    # An idle transmitter starts again at once.
    radio.send(1, 2, bytes(size), "data")
    sched.run_until(10.0)
    assert log[-1][0] == pytest.approx(5.0 + size / bandwidth + latency)


def test_corrupted_delivery_passes_different_bytes() -> None:
    data = wire.encode(
        swarm="s",
        sender=1,
        incarnation=1,
        seq=1,
        body=wire.Heartbeat(is_master=False, epoch=0, master=0),
    )
    sched, radio, log = make(LinkModel(corrupt=1.0), platforms=4)
    for _ in range(20):
        radio.send(1, None, data, "heartbeat")
    sched.run_until(1.0)
    assert len(log) == 60
    assert all(entry[4] for entry in log)
    assert all(entry[3] != data for entry in log)
    assert len({entry[3] for entry in log}) > 1  # damage is random, not one fixed pattern


def test_corrupted_transmission_decodes_its_own_bytes() -> None:
    data = wire.encode(
        swarm="s",
        sender=1,
        incarnation=1,
        seq=1,
        body=wire.Heartbeat(is_master=False, epoch=0, master=0),
    )
    sched = Scheduler()
    radio = SimRadio(sched, random.Random(5), LinkModel(corrupt=1.0), decoder=wire.decode)
    outcomes: list[str] = []

    def deliver(tx: Transmission[wire.Packet], now: float) -> None:
        assert tx.corrupted
        try:
            packet = tx.packet()
        except wire.WireError as exc:
            outcomes.append(exc.reason)
        else:
            outcomes.append("decoded")
            assert isinstance(packet, wire.Packet)

    radio.attach(1, lambda tx, now: None)
    radio.attach(2, deliver)
    for _ in range(50):
        radio.send(1, 2, data, "heartbeat")
    sched.run_until(1.0)
    assert len(outcomes) == 50
    assert "decoded" not in outcomes or len(set(outcomes)) > 1


# --- partitions ---------------------------------------------------------------------------


def test_partition_blocks_and_heal_restores() -> None:
    sched, radio, log = make(LinkModel(), platforms=5)
    radio.partition([[1, 2], [3]])
    assert radio.connected(1, 2)
    assert not radio.connected(1, 3)
    assert radio.connected(4, 5)  # the unlisted form one group
    assert not radio.connected(2, 4)
    assert radio.components([5, 1, 2, 3, 4]) == [
        frozenset({1, 2}),
        frozenset({3}),
        frozenset({4, 5}),
    ]
    radio.send(1, None, b"p", "heartbeat")
    radio.send(4, 3, b"q", "data")
    sched.run_until(1.0)
    assert [(entry[1], entry[3]) for entry in log] == [(2, b"p")]
    assert radio.drops["partition"] == 4  # 3, 4 and 5 for the broadcast; 3 for the unicast

    radio.heal()
    assert radio.components(range(1, 6)) == [frozenset(range(1, 6))]
    log.clear()
    radio.send(1, None, b"r", "heartbeat")
    sched.run_until(2.0)
    assert [entry[1] for entry in log] == [2, 3, 4, 5]


def test_partition_checked_at_send_and_at_delivery() -> None:
    sched, radio, log = make(LinkModel(latency=0.1), platforms=3)
    radio.send(1, 2, b"cut in flight", "data")
    sched.run_until(0.05)
    radio.partition([[1], [2, 3]])
    sched.run_until(0.5)
    assert log == []

    radio.send(1, 2, b"sent while cut", "data")
    sched.run_until(0.55)
    radio.heal()
    sched.run_until(1.0)
    assert log == []
    assert radio.drops["partition"] == 2


def test_partition_during_a_jittered_broadcast_stops_the_rest() -> None:
    sched, radio, log = make(LinkModel(latency=0.0, jitter=1.0), platforms=40)
    radio.send(1, None, b"spread out", "heartbeat")
    sched.run_until(0.5)
    early = {entry[1] for entry in log}
    assert 0 < len(early) < 39
    radio.partition([[1]])
    sched.run_until(2.0)
    assert {entry[1] for entry in log} == early
    assert radio.drops["partition"] == 39 - len(early)


def test_partition_validation() -> None:
    _, radio, _ = make(LinkModel())
    with pytest.raises(ValueError, match="platform 2 is in partition groups 0 and 1"):
        radio.partition([[1, 2], [2, 3]])


# --- crashes ------------------------------------------------------------------------------


def test_platform_detached_mid_flight_does_not_receive() -> None:
    sched, radio, log = make(LinkModel(latency=0.1), platforms=3)
    radio.send(1, None, b"bcast", "heartbeat")
    radio.send(1, 2, b"ucast", "data")
    sched.run_until(0.05)
    radio.detach(2)
    sched.run_until(1.0)
    assert [(entry[1], entry[3]) for entry in log] == [(3, b"bcast")]
    assert radio.drops["detached"] == 2
    assert radio.traffic.totals(2) == (0, 0, 0, 0)


def test_detached_platform_does_not_send_and_unknown_destination_drops() -> None:
    sched, radio, log = make(LinkModel(), platforms=3)
    radio.detach(1)
    radio.send(1, None, b"ghost", "heartbeat")
    assert radio.traffic.totals(1) == (0, 0, 0, 0)
    radio.send(2, 99, b"nobody", "data")
    assert radio.traffic.totals(2) == (1, 6, 0, 0)  # counted as sent
    sched.run_until(1.0)
    assert log == []
    assert radio.drops["detached"] == 2
    # Re-attached (a reboot): on the air again.
    attach_logger(radio, 1, log)
    radio.send(2, 1, b"back", "data")
    sched.run_until(2.0)
    assert [(entry[1], entry[3]) for entry in log] == [(1, b"back")]


def test_sender_crash_loses_packets_still_in_its_transmitter() -> None:
    sched, radio, log = make(LinkModel(latency=0.0, bandwidth=100.0), platforms=2)
    for i in range(5):
        radio.send(1, 2, seq_bytes(i) + bytes(96), "data")  # 1 s on the air each
    sched.run_until(2.5)  # two delivered, the third is being transmitted
    radio.detach(1)
    sched.run_until(10.0)
    assert [int.from_bytes(entry[3][:4], "big") for entry in log] == [0, 1]
    assert radio.drops["detached"] == 3
    # After a reboot the transmitter is idle: no wait for the packets that were lost.
    attach_logger(radio, 1, log)
    radio.send(1, 2, bytes(100), "data")
    sched.run_until(20.0)
    assert log[-1][0] == pytest.approx(11.0)


# --- counters and decoding ----------------------------------------------------------------


def test_broadcast_counted_once_at_sender_and_once_per_receiver() -> None:
    sched, radio, _ = make(LinkModel(), platforms=4)
    radio.send(1, None, b"12345", "heartbeat")
    radio.send(2, 1, b"123", "data")
    sched.run_until(1.0)
    traffic = radio.traffic
    assert traffic.totals(1) == (1, 5, 1, 3)
    assert traffic.totals(2) == (1, 3, 1, 5)
    assert traffic.totals(3) == (0, 0, 1, 5)
    assert traffic.totals(4) == (0, 0, 1, 5)
    assert traffic.totals(99) == (0, 0, 0, 0)
    assert traffic.kind_totals("heartbeat") == (1, 5, 3, 15)
    assert traffic.kind_totals("data") == (1, 3, 1, 3)
    assert traffic.kinds == ["data", "heartbeat"]
    snap = traffic.snapshot()
    assert list(snap) == [1, 2, 3, 4]
    assert snap[1] == {
        "sent_packets": 1,
        "sent_bytes": 5,
        "recv_packets": 1,
        "recv_bytes": 3,
        "by_kind": {
            "data": {"sent_packets": 0, "sent_bytes": 0, "recv_packets": 1, "recv_bytes": 3},
            "heartbeat": {"sent_packets": 1, "sent_bytes": 5, "recv_packets": 0, "recv_bytes": 0},
        },
    }
    assert snap[3]["by_kind"] == {
        "heartbeat": {"sent_packets": 0, "sent_bytes": 0, "recv_packets": 1, "recv_bytes": 5}
    }


def test_broadcast_is_decoded_once() -> None:
    calls: list[bytes] = []

    def counting_decode(data: bytes) -> wire.Packet:
        calls.append(data)
        return wire.decode(data, swarm="s")

    sched = Scheduler()
    radio = SimRadio(sched, random.Random(1), LinkModel(), decoder=counting_decode)
    senders: list[tuple[int, int]] = []

    def receiver(platform: int) -> Callable[[Transmission[wire.Packet], float], None]:
        def deliver(tx: Transmission[wire.Packet], now: float) -> None:
            senders.append((platform, tx.packet().sender))

        return deliver

    for p in range(1, 21):
        radio.attach(p, receiver(p))
    for sender in (3, 7):
        data = wire.encode(
            swarm="s",
            sender=sender,
            incarnation=1,
            seq=1,
            body=wire.Heartbeat(is_master=False, epoch=0, master=0),
        )
        radio.send(sender, None, data, "heartbeat")
    sched.run_until(1.0)
    assert len(senders) == 38
    assert {sender for _, sender in senders} == {3, 7}
    assert len(calls) == 2


def test_decoding_failure_is_cached_too() -> None:
    calls: list[bytes] = []

    def counting_decode(data: bytes) -> wire.Packet:
        calls.append(data)
        return wire.decode(data)

    sched = Scheduler()
    radio = SimRadio(sched, random.Random(1), LinkModel(), decoder=counting_decode)
    reasons: list[str] = []

    def deliver(tx: Transmission[wire.Packet], now: float) -> None:
        try:
            tx.packet()
        except wire.WireError as exc:
            reasons.append(exc.reason)

    for p in range(1, 6):
        radio.attach(p, deliver)
    radio.send(1, None, b"\xc1garbage", "junk")
    sched.run_until(1.0)
    assert reasons == ["checksum"] * 4
    assert len(calls) == 1
