"""The shared channel's arithmetic (:mod:`actorswarm.core.membership.airtime`): the cadence a master
asks for, the size it implies, a handshake's airtime, the swarm's channel time, and the log
of platforms heard. Without a channel each is the fast network's value."""

from __future__ import annotations

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.core.membership import airtime

MBIT = CoreConfig(channel_bitrate=1e6)
FAST = CoreConfig()


@pytest.mark.parametrize(("others", "cadence"), [(1, 0.1), (62, 0.1), (100, 0.16), (999, 1.5984)])
def test_the_cadence_keeps_heartbeats_to_half_the_channel(others: int, cadence: float) -> None:
    assert airtime.member_cadence(MBIT, others) == pytest.approx(cadence)
    assert airtime.member_cadence(FAST, others) == FAST.heartbeat_interval


@pytest.mark.parametrize("others", [100, 299, 999, 5000])
def test_a_cadence_implies_the_size_it_was_asked_for(others: int) -> None:
    cadence = airtime.member_cadence(MBIT, others)
    assert airtime.implied_size(MBIT, cadence) in (others - 1, others)
    assert airtime.implied_size(MBIT, MBIT.heartbeat_interval) == 0
    assert airtime.implied_size(FAST, cadence) == 0


def test_a_handshake_and_a_swarm_take_their_airtime() -> None:
    # 100 members × 6 heartbeats' worth × 800 bits in half of 1 Mbit/s
    assert airtime.handshake_airtime(MBIT, 100) == pytest.approx(0.96)
    assert airtime.channel_time(MBIT, 1000) == pytest.approx(0.8)
    assert airtime.handshake_airtime(FAST, 100) == 0.0
    assert airtime.channel_time(FAST, 1000) == 0.0


def test_the_heard_log_forgets_after_its_horizon_once_a_second() -> None:
    log = airtime.HeardLog(0.0)
    log.heard(5, 0.0)
    log.heard(6, 3.0)
    log.heard(5, 0.5)  # heard again: the later time counts
    assert len(log) == 2
    log.sweep(airtime.HEARD_HORIZON + 0.4)  # 5 is 0.1 s short of forgotten
    assert len(log) == 2
    log.sweep(airtime.HEARD_HORIZON + 0.6)  # less than a second since the last sweep
    assert len(log) == 2
    log.sweep(airtime.HEARD_HORIZON + 1.5)
    assert len(log) == 1
    log.sweep(airtime.HEARD_HORIZON + 3.5)
    assert len(log) == 0
