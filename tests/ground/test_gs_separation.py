"""A real swarm's separation at its ground station, from the positions its platforms report."""

from __future__ import annotations

import pytest

from actorswarm.ground.separation import SwarmSeparation


def test_reported_positions_are_measured_fresh_and_airborne_only() -> None:
    sep = SwarmSeparation(minimum=5.0, max_age=1.0)
    sep.position(0.0, 3, (0.0, 0.0, 20.0))
    sep.position(0.0, 7, (3.0, 4.0, 20.0))  # 5 m: kept
    sep.position(0.0, 9, (100.0, 0.0, 0.0))  # on the ground
    assert sep.observe(0.1) == []
    sep.position(0.5, 7, (1.0, 1.0, 20.0))
    (breach,) = sep.observe(0.6)
    assert (breach.closest.a, breach.closest.b) == (3, 7)
    assert breach.closest.distance == pytest.approx(2**0.5)
    # Platform 3 says nothing more: its position goes stale and is not compared.
    sep.position(2.0, 7, (0.5, 0.0, 20.0))
    assert sep.observe(2.1) == []
    sep.position(2.0, 9, (0.0, 0.5, 0.0))  # close, but on the ground
    assert sep.observe(2.2) == []
    report = sep.result()
    assert len(report.breaches) == 1 and report.minimums == {"every pair": 5.0}


def test_a_bad_minimum_is_refused() -> None:
    with pytest.raises(ValueError, match="--min-separation must be metres > 0"):
        SwarmSeparation(minimum=0.0)
