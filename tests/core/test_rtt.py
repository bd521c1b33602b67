"""The round-trip estimator behind adaptive retransmission delays."""

from __future__ import annotations

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.core.delivery.reliable import Reliable
from actorswarm.core.delivery.rtt import RttEstimator
from actorswarm.core.wire import NORMAL, Ack, AppMessage


def test_initial_timeout_before_any_sample() -> None:
    est = RttEstimator(initial=0.04, floor=0.01, cap=0.4)
    assert est.timeout == 0.04


@pytest.mark.parametrize("rtt", [0.002, 0.02, 0.06, 0.2])
def test_steady_round_trips_converge_to_rtt_plus_floor(rtt: float) -> None:
    est = RttEstimator(initial=0.04, floor=0.01, cap=0.4)
    for _ in range(60):
        est.sample(rtt)
    assert est.srtt == pytest.approx(rtt)
    assert est.timeout == pytest.approx(rtt + 0.01, abs=1e-4), "variation vanished: srtt + floor"


def test_jitter_raises_the_timeout_and_cap_bounds_it() -> None:
    steady = RttEstimator(initial=0.04, floor=0.01, cap=0.4)
    jittery = RttEstimator(initial=0.04, floor=0.01, cap=0.4)
    for i in range(60):
        steady.sample(0.02)
        jittery.sample(0.01 if i % 2 else 0.03)
    assert jittery.timeout > steady.timeout
    slow = RttEstimator(initial=0.04, floor=0.01, cap=0.4)
    slow.sample(5.0)
    assert slow.timeout == 0.4


def test_reliable_learns_rtt_only_from_messages_sent_once() -> None:
    r = Reliable(CoreConfig(retry_base=0.04, retry_min=0.005, adaptive_retry=True))
    r.send(2, AppMessage(topic="t", body=b"1"), 0.0, 0)
    r.on_ack(2, Ack(dst=1, dst_incarnation=0, channel=NORMAL, seq=1), 0.02)
    # First sample: srtt = R, rttvar = R/2, so the timeout is R + 4 * R/2.
    assert r.timeout(2) == pytest.approx(0.02 + 0.04, abs=1e-9)
    # A retransmitted message gives no sample (Karn's rule).
    r.send(2, AppMessage(topic="t", body=b"2"), 1.0, 0)
    r.tick(1.0 + r.timeout(2) + 1e-6)
    before = r.timeout(2)
    r.on_ack(2, Ack(dst=1, dst_incarnation=0, channel=NORMAL, seq=2), 1.5)
    assert r.timeout(2) == before
    assert r.timeout(None) == pytest.approx(before), "broadcasts use the estimate of everyone"


def test_fixed_retry_when_adaptive_is_off() -> None:
    r = Reliable(CoreConfig(adaptive_retry=False, retry_base=0.05))
    r.send(2, AppMessage(topic="t", body=b"1"), 0.0, 0)
    r.on_ack(2, Ack(dst=1, dst_incarnation=0, channel=NORMAL, seq=1), 0.001)
    assert r.timeout(2) == 0.05
