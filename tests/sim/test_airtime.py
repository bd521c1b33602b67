"""The simulated radio's shared channel: airtime, FIFO serialization, drops, channel load."""

from __future__ import annotations

import json
import math
import random
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.sim.radio import Airtime, ChannelStats, LinkModel, SimRadio, Transmission
from actorswarm.sim.scheduler import Scheduler

# (delivery time, receiver, sender, bytes, corrupted)
Log = list[tuple[float, int, int, bytes, bool]]

# Numbers chosen to be exact in binary floating point, so times compare with ==: a 128-byte
# packet without overhead is 1024 bits, 1/64 s on a 65 536 bit/s channel.
BITRATE = 65_536.0
SIZE = 128
SLOT = 1 / 64
LATENCY = 0.0078125  # 1/128 s
EXACT = Airtime(bitrate=BITRATE, overhead_bytes=0, max_queue_s=math.inf)


def _identity(data: bytes) -> bytes:
    return data


def make(
    model: LinkModel | None = None,
    *,
    airtime: Airtime | None = None,
    platforms: int = 5,
    seed: int = 1,
) -> tuple[Scheduler, SimRadio[bytes], Log]:
    sched = Scheduler()
    radio = SimRadio(
        sched,
        random.Random(seed),
        model or LinkModel(latency=LATENCY),
        decoder=_identity,
        airtime=airtime,
    )
    log: Log = []
    for p in range(1, platforms + 1):
        attach_logger(radio, p, log)
    return sched, radio, log


def attach_logger(radio: SimRadio[bytes], platform: int, log: Log) -> None:
    def deliver(tx: Transmission[bytes], now: float) -> None:
        log.append((now, platform, tx.src, tx.data, tx.corrupted))

    radio.attach(platform, deliver)


def packet(i: int, size: int = SIZE) -> bytes:
    return i.to_bytes(4, "big") + bytes(size - 4)


# --- configuration ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"bitrate": 0.0}, r"Airtime\.bitrate must be a finite number of bits/s > 0"),
        ({"bitrate": -1e6}, r"Airtime\.bitrate"),
        ({"bitrate": math.nan}, r"Airtime\.bitrate"),
        ({"bitrate": math.inf}, r"Airtime\.bitrate"),
        ({"bitrate": 1e6, "overhead_bytes": -1}, r"Airtime\.overhead_bytes must be an integer"),
        ({"bitrate": 1e6, "overhead_bytes": 1.5}, r"Airtime\.overhead_bytes"),
        ({"bitrate": 1e6, "overhead_bytes": True}, r"Airtime\.overhead_bytes"),
        ({"bitrate": 1e6, "max_queue_s": -0.1}, r"Airtime\.max_queue_s must be a number"),
        ({"bitrate": 1e6, "max_queue_s": math.nan}, r"Airtime\.max_queue_s"),
    ],
)
def test_invalid_airtime_is_refused_naming_the_field(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Airtime(**kwargs)


def test_valid_extremes_are_accepted() -> None:
    assert Airtime(bitrate=1.0, overhead_bytes=0, max_queue_s=0.0).max_queue_s == 0.0
    assert Airtime(bitrate=1e9, max_queue_s=math.inf).max_queue_s == math.inf


# --- one packet, back to back, broadcast ----------------------------------------------------


def test_channel_time_of_one_packet() -> None:
    airtime = Airtime(bitrate=1_000_000.0, overhead_bytes=28)
    assert airtime.seconds(100) == pytest.approx((100 + 28) * 8 / 1_000_000.0)
    assert airtime.seconds(0) == pytest.approx(28 * 8 / 1_000_000.0)
    sched, radio, log = make(LinkModel(latency=0.01), airtime=airtime, platforms=2)
    sched.run_until(1.0)
    radio.send(1, 2, bytes(100), "data")
    sched.run_until(2.0)
    assert len(log) == 1
    assert log[0][0] == pytest.approx(1.0 + airtime.seconds(100) + 0.01)


def test_back_to_back_packets_are_serialized_in_the_order_sent() -> None:
    sched, radio, log = make(airtime=EXACT, platforms=5)
    # Different senders, one channel: each waits for the packets sent before it.
    for i in range(8):
        radio.send(1 + i % 4, 5, packet(i), "data")
    sched.run_until(1.0)
    assert [int.from_bytes(entry[3][:4], "big") for entry in log] == list(range(8))
    assert [entry[0] for entry in log] == [(k + 1) * SLOT + LATENCY for k in range(8)]


def test_an_idle_channel_starts_a_packet_at_once() -> None:
    sched, radio, log = make(airtime=EXACT, platforms=2)
    radio.send(1, 2, packet(0), "data")
    sched.run_until(0.5)
    radio.send(2, 1, packet(1), "data")
    sched.run_until(1.0)
    assert [entry[0] for entry in log] == [SLOT + LATENCY, 0.5 + SLOT + LATENCY]
    assert radio.channel_stats().max_queue_delay_s == 0.0


def test_a_broadcast_occupies_the_channel_once() -> None:
    sched, radio, log = make(airtime=EXACT, platforms=10)
    radio.send(1, None, packet(0), "heartbeat")
    assert sched.pending == 1  # still one event for nine receivers
    radio.send(2, 3, packet(1), "data")
    sched.run_until(1.0)
    heard = [entry for entry in log if entry[2] == 1]
    assert sorted(entry[1] for entry in heard) == list(range(2, 11))
    assert {entry[0] for entry in heard} == {SLOT + LATENCY}
    # The unicast waited for one packet's airtime, not nine.
    assert [entry[0] for entry in log if entry[2] == 2] == [2 * SLOT + LATENCY]
    stats = radio.channel_stats()
    assert (stats.packets, stats.bits, stats.busy_s) == (2, 2 * SIZE * 8, 2 * SLOT)


def test_latency_and_jitter_come_on_top_of_the_airtime() -> None:
    model = LinkModel(latency=LATENCY, jitter=0.005)
    sched, radio, log = make(model, airtime=EXACT, platforms=6)
    radio.send(1, None, packet(0), "heartbeat")
    radio.send(2, None, packet(1), "heartbeat")
    sched.run_until(1.0)
    for src, slot in ((1, 1), (2, 2)):
        times = [entry[0] for entry in log if entry[2] == src]
        assert len(times) == 5
        assert all(slot * SLOT + LATENCY <= t <= slot * SLOT + LATENCY + 0.005 for t in times)


def test_a_slow_sender_holds_the_channel_for_its_own_transmission_time() -> None:
    # 128 bytes at 4096 bytes/s: 1/32 s, twice the channel's airtime.
    sched, radio, log = make(LinkModel(latency=LATENCY, bandwidth=4096.0), airtime=EXACT)
    radio.send(1, 2, packet(0), "data")
    radio.send(3, 2, packet(1), "data")
    sched.run_until(1.0)
    assert [entry[0] for entry in log] == [2 * SLOT + LATENCY, 4 * SLOT + LATENCY]


def test_a_detached_sender_loses_its_queued_packets_but_not_their_channel_time() -> None:
    sched, radio, log = make(airtime=EXACT, platforms=3)
    radio.send(1, 3, packet(0), "data")
    radio.send(1, 3, packet(1), "data")  # on the air from 1/64 to 2/64
    sched.run_until(SLOT / 2)
    radio.detach(1)
    radio.send(2, 3, packet(2), "data")  # still waits for 1's reservation
    sched.run_until(1.0)
    assert [(entry[0], entry[2]) for entry in log] == [(3 * SLOT + LATENCY, 2)]
    assert radio.drops["detached"] == 2


# --- overload -----------------------------------------------------------------------------


def test_overload_drops_what_would_wait_longer_than_max_queue_and_counts_it() -> None:
    airtime = Airtime(bitrate=BITRATE, overhead_bytes=0, max_queue_s=5 * SLOT)
    sched, radio, log = make(airtime=airtime, platforms=4)
    for i in range(20):
        radio.send(1, 2, packet(i), "data")
    radio.send(3, None, packet(20), "heartbeat")  # would reach 3 receivers
    sched.run_until(1.0)
    # Waits of 0, 1/64 ... 5/64 are allowed: six packets go out, the rest are dropped.
    assert [int.from_bytes(entry[3][:4], "big") for entry in log] == list(range(6))
    stats = radio.channel_stats()
    assert stats.packets == 6
    assert stats.drops == 15
    assert dict(stats.drops_by_kind) == {"data": 14, "heartbeat": 1}
    assert stats.max_queue_delay_s == 5 * SLOT
    assert radio.drops["airtime"] == 14 + 3  # per receiver, as every cause is counted
    # A dropped packet was still sent by its platform.
    assert radio.traffic.totals(1)[0] == 20
    # Once the queue has drained, packets go through again.
    radio.send(1, 2, packet(21), "data")
    sched.run_until(2.0)
    assert log[-1][0] == 1.0 + SLOT + LATENCY


def test_max_queue_zero_drops_whatever_finds_the_channel_busy() -> None:
    airtime = Airtime(bitrate=BITRATE, overhead_bytes=0, max_queue_s=0.0)
    sched, radio, log = make(airtime=airtime, platforms=3)
    radio.send(1, 2, packet(0), "data")
    radio.send(3, 2, packet(1), "data")
    sched.run_until(SLOT)  # the channel is free again exactly now
    radio.send(3, 2, packet(2), "data")
    sched.run_until(1.0)
    assert [int.from_bytes(entry[3][:4], "big") for entry in log] == [0, 2]
    assert radio.channel_stats().drops == 1


# --- off: unchanged -----------------------------------------------------------------------

FAULTY = LinkModel(
    loss=0.1,
    latency=0.01,
    jitter=0.004,
    duplicate=0.1,
    reorder=0.2,
    reorder_delay=0.03,
    corrupt=0.05,
)


def _broadcast(step: int) -> bool:
    """Whether step ``step`` of :func:`run_traffic` broadcasts (40 bytes) or not (60)."""
    src = 1 + step % 6
    return step % 3 == 0 or 1 + (src + step) % 6 == src


def run_traffic(
    seed: int, airtime: Airtime | None, *, pass_airtime: bool = True, model: LinkModel = FAULTY
) -> tuple[Log, dict[str, int], ChannelStats]:
    sched = Scheduler()
    if pass_airtime:
        radio = SimRadio(sched, random.Random(seed), model, decoder=_identity, airtime=airtime)
    else:
        radio = SimRadio(sched, random.Random(seed), model, decoder=_identity)
    log: Log = []
    for p in range(1, 7):
        attach_logger(radio, p, log)
    for step in range(300):
        sched.run_until(step * 0.002)
        src = 1 + step % 6
        if _broadcast(step):
            radio.send(src, None, packet(step, 40), "heartbeat")
        else:
            radio.send(src, 1 + (src + step) % 6, packet(step, 60), "data")
    sched.run_until(10.0)
    return log, dict(radio.drops), radio.channel_stats()


@pytest.mark.parametrize("model", [FAULTY, LinkModel(), LinkModel(bandwidth=20_000.0)])
def test_off_is_the_run_without_airtime(model: LinkModel) -> None:
    log, drops, stats = run_traffic(7, None, model=model)
    assert (log, drops) == run_traffic(7, None, pass_airtime=False, model=model)[:2]
    assert drops["airtime"] == 0
    if model == LinkModel():
        # Without airtime or faults a packet arrives exactly its latency after it is sent.
        assert all(t == int.from_bytes(d[:4], "big") * 0.002 + 0.01 for t, _, _, d, _ in log)
    # The load is counted all the same, a broadcast once.
    payload = sum(40 if _broadcast(step) else 60 for step in range(300))
    assert (stats.packets, stats.bits) == (300, payload * 8)
    assert (stats.bitrate, stats.utilisation, stats.busy_s) == (None, None, 0.0)
    assert (stats.drops, stats.max_queue_delay_s) == (0, 0.0)


def test_a_fast_channel_changes_the_times_only() -> None:
    off = run_traffic(7, None)[0]
    on = run_traffic(7, Airtime(bitrate=1e9, max_queue_s=math.inf))[0]
    # The same faults are drawn in the same order; only the airtime is added.
    assert [entry[1:] for entry in on] == [entry[1:] for entry in off]
    assert all(0 < a[0] - b[0] < 1e-5 for a, b in zip(on, off, strict=True))


def test_same_seed_same_run_with_airtime() -> None:
    airtime = Airtime(bitrate=200_000.0, max_queue_s=0.01)
    first = run_traffic(3, airtime)
    assert first == run_traffic(3, airtime)
    assert first[2].drops > 0  # the channel is overloaded: the queue limit matters
    assert first[0] != run_traffic(4, airtime)[0]


def test_airtime_can_be_switched_on_mid_run() -> None:
    sched, radio, log = make(platforms=2)
    radio.send(1, 2, packet(0), "data")
    radio.send(1, 2, packet(1), "data")
    sched.run_until(1.0)
    radio.airtime = EXACT
    radio.send(1, 2, packet(2), "data")
    radio.send(1, 2, packet(3), "data")
    sched.run_until(2.0)
    assert [entry[0] for entry in log] == [
        LATENCY,
        LATENCY,
        1.0 + SLOT + LATENCY,
        1.0 + 2 * SLOT + LATENCY,
    ]
    radio.airtime = None
    assert radio.airtime is None


# --- the snapshot -------------------------------------------------------------------------


def test_snapshot_of_a_scripted_scenario() -> None:
    sched, radio, _ = make(airtime=EXACT, platforms=3)
    for i in range(4):
        radio.send(1 + i % 2, None, packet(i), "heartbeat")  # busy from 0 to 4/64
    sched.run_until(2 * SLOT)
    # Half way through: only the channel time already past counts as busy.
    early = radio.channel_stats()
    assert (early.elapsed_s, early.busy_s, early.utilisation) == (2 * SLOT, 2 * SLOT, 1.0)
    assert early.packets == 4
    sched.run_until(1.0)
    radio.send(3, 1, packet(4), "data")
    radio.send(3, 1, packet(5), "data")
    sched.run_until(2.0)
    stats = radio.channel_stats()
    assert stats == ChannelStats(
        start_s=0.0,
        elapsed_s=2.0,
        packets=6,
        bits=6 * SIZE * 8,
        packets_per_s=3.0,
        bits_per_s=3.0 * SIZE * 8,
        bitrate=BITRATE,
        busy_s=6 * SLOT,
        utilisation=6 * SLOT / 2.0,
        drops=0,
        drops_by_kind={},
        max_queue_delay_s=3 * SLOT,
        relayed=0,
    )
    as_dict = stats.as_dict()
    assert json.loads(json.dumps(as_dict)) == as_dict
    assert set(as_dict) == {
        "start_s",
        "elapsed_s",
        "packets",
        "bits",
        "packets_per_s",
        "bits_per_s",
        "bitrate",
        "busy_s",
        "utilisation",
        "drops",
        "drops_by_kind",
        "max_queue_delay_s",
        "relayed",
    }


def test_overhead_counts_on_the_air() -> None:
    airtime = Airtime(bitrate=BITRATE, overhead_bytes=32)
    sched, radio, log = make(airtime=airtime, platforms=2)
    radio.send(1, 2, bytes(96), "data")
    sched.run_until(1.0)
    assert log[0][0] == SLOT + LATENCY  # 96 + 32 bytes: one slot
    assert radio.channel_stats().bits == SIZE * 8


def test_reset_starts_a_new_window_that_keeps_the_channel_time_still_ahead() -> None:
    sched, radio, _ = make(airtime=EXACT, platforms=2)
    for i in range(4):
        radio.send(1, 2, packet(i), "data")  # busy from 0 to 4/64
    sched.run_until(SLOT)
    radio.reset_channel_stats()
    sched.run_until(0.5)
    stats = radio.channel_stats()
    assert (stats.start_s, stats.elapsed_s) == (SLOT, 0.5 - SLOT)
    assert (stats.packets, stats.bits, stats.max_queue_delay_s) == (0, 0, 0.0)
    assert stats.busy_s == 3 * SLOT  # what was still queued when the window began
    assert stats.utilisation == pytest.approx(3 * SLOT / (0.5 - SLOT))


def test_an_empty_window_has_zero_rates() -> None:
    _, radio, _ = make(airtime=EXACT)
    stats = radio.channel_stats()
    assert (stats.elapsed_s, stats.packets_per_s, stats.bits_per_s) == (0.0, 0.0, 0.0)
    assert stats.utilisation == 0.0


def test_unsent_packets_are_not_on_the_air() -> None:
    _, radio, _ = make(airtime=EXACT, platforms=3)
    radio.detach(3)
    radio.send(3, 1, packet(0), "data")  # from a detached platform: never sent
    radio.send(1, 3, packet(1), "data")  # to a detached platform: transmitted all the same
    assert radio.channel_stats().packets == 1


# --- the CLI ------------------------------------------------------------------------------

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "branch_merge.xml"
runner = CliRunner()


def _sim(*extra: str) -> Any:
    args = ["sim", str(EXAMPLE), "--no-world", "--duration", "3", *extra]
    return runner.invoke(app, args)


def test_cli_channel_bitrate_reaches_the_json_report() -> None:
    result = _sim("--channel-bitrate", "1e6", "--json", "-")
    assert result.exit_code == 0, result.output
    channel = json.loads(result.output)["channel"]
    assert channel["bitrate"] == 1e6
    assert channel["packets"] > 0 and channel["bits"] > 0
    assert 0.0 < channel["utilisation"] < 1.0
    assert channel["elapsed_s"] == pytest.approx(3.0)


def test_cli_reports_the_channel_load_without_airtime_too() -> None:
    result = _sim("--json", "-")
    assert result.exit_code == 0, result.output
    channel = json.loads(result.output)["channel"]
    assert channel["bitrate"] is None and channel["utilisation"] is None
    assert channel["packets"] > 0


def test_cli_summary_has_a_channel_line_and_a_bad_bitrate_is_refused() -> None:
    result = _sim("--channel-bitrate", "250000")
    assert result.exit_code == 0, result.output
    assert "channel: " in result.output and "250,000 bit/s" in result.output
    result = _sim("--channel-bitrate", "0")
    assert result.exit_code == 2
    assert "--channel-bitrate" in result.output and "Airtime.bitrate" in result.output


# --- relays ---------------------------------------------------------------------------------


def test_each_relay_sending_a_packet_on_holds_the_channel_once_more() -> None:
    """A broadcast forwarded by two relays is three transmissions on the air; a unicast
    over one relay two. The packet itself arrives when its own transmission ends; the
    relays' follow it on the channel, so the next packet waits for them."""
    sched, radio, log = make(airtime=EXACT)
    asked: list[tuple[int, int | None]] = []

    def relays(src: int, dst: int | None) -> int:
        asked.append((src, dst))
        return 2 if dst is None else 1

    radio.relay_fn = relays
    radio.send(1, None, packet(0), "heartbeat")
    radio.send(2, 3, packet(1), "data")
    sched.run_until(1.0)
    assert asked == [(1, None), (2, 3)]
    assert {t for t, _, src, _, _ in log if src == 1} == {SLOT + LATENCY}
    # The unicast waited for the broadcast and its two relays: 3 slots, then its own.
    assert [t for t, _, src, _, _ in log if src == 2] == [4 * SLOT + LATENCY]
    stats = radio.channel_stats()
    assert (stats.packets, stats.relayed, stats.bits) == (5, 3, 5 * SIZE * 8)
    assert stats.busy_s == 5 * SLOT and stats.max_queue_delay_s == 3 * SLOT
    assert stats.as_dict()["relayed"] == 3


def test_relays_count_on_the_air_without_airtime_too() -> None:
    sched, radio, _ = make()
    radio.relay_fn = lambda src, dst: 3
    radio.send(1, None, packet(0), "heartbeat")
    sched.run_until(1.0)
    stats = radio.channel_stats()
    assert (stats.packets, stats.relayed, stats.bits, stats.busy_s) == (4, 3, 4 * SIZE * 8, 0.0)
    # What the platforms sent is counted at the sender once: the relays are the air's.
    assert radio.traffic.totals(1)[:2] == (1, SIZE)
