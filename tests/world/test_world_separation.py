"""The separation monitor: the least distance of airborne pairs, the closest pairs, breaches
against each kind's minimum, and a breach that stops a run."""

from __future__ import annotations

import numpy as np
import pytest

from actorswarm.world.config import WorldError, loads_world
from actorswarm.world.separation import (
    BREACH_PREFIX,
    SeparationBreachError,
    SeparationMonitor,
    separation_line,
)


def _fly(monitor: SeparationMonitor, gaps: list[float], *, z: float = 20.0) -> None:
    """Two vehicles ``gap`` metres apart along x at t = 0, 1, 2, ...; a third far away."""
    for t, gap in enumerate(gaps):
        pos = np.array([[0.0, 0.0, z], [gap, 0.0, z], [500.0, 0.0, z]])
        monitor.observe(float(t), pos, np.ones(3, dtype=bool))


def test_least_distance_closest_pairs_and_one_breach_per_stretch() -> None:
    monitor = SeparationMonitor([1, 2, 3], [3.0, 3.0, 3.0])
    _fly(monitor, [10.0, 5.0, 2.5, 1.0, 2.0, 8.0, 2.9, 9.0])
    report = monitor.result()
    assert report.closest is not None
    assert (report.closest.a, report.closest.b) == (1, 2)
    assert report.closest.distance == pytest.approx(1.0)
    assert report.closest.t == 3.0
    assert report.closest.where == pytest.approx((0.5, 0.0, 20.0))
    # Closer than 3 m from t = 2 to t = 4, then again at t = 6: two breaches.
    assert [(b.start, b.end) for b in report.breaches] == [(2.0, 4.0), (6.0, 6.0)]
    assert report.breaches[0].closest.distance == pytest.approx(1.0)
    assert report.breach_samples == 4 and report.samples == 8
    assert [(e.a, e.b) for e in report.pairs] == [(1, 2)]
    lines = report.violations()
    assert len(lines) == 2 and all(line.startswith(BREACH_PREFIX) for line in lines)
    assert "platforms 1 and 2 1.00 m apart at t = 3.0 s" in lines[0]
    assert "BREACH" in separation_line(report.as_dict())


def test_a_mixed_pair_keeps_the_larger_minimum() -> None:
    monitor = SeparationMonitor([1, 2, 3], [3.0, 10.0, 3.0])  # 2 is a fixed-wing
    _fly(monitor, [6.0])
    (breach,) = monitor.result().breaches
    assert breach.closest.minimum == 10.0
    quads = SeparationMonitor([1, 2, 3], [3.0, 3.0, 3.0])
    _fly(quads, [6.0])
    assert quads.result().held


def test_vehicles_on_the_ground_do_not_count() -> None:
    monitor = SeparationMonitor([1, 2, 3], [3.0, 3.0, 3.0])
    _fly(monitor, [0.5], z=0.0)  # parked side by side
    pos = np.array([[0.0, 0.0, 20.0], [1.0, 0.0, 20.0], [500.0, 0.0, 20.0]])
    monitor.observe(1.0, pos, np.array([True, False, True]))  # 2 landed, say
    report = monitor.result()
    assert report.held
    assert report.closest is not None and report.closest.distance == pytest.approx(500.0)
    assert "held at every instant" in separation_line(report.as_dict())


def test_a_fatal_monitor_raises_at_the_first_breach() -> None:
    monitor = SeparationMonitor([1, 2, 3], [3.0, 3.0, 3.0], fatal=True)
    with pytest.raises(SeparationBreachError, match=r"platforms 1 and 2 2\.00 m apart"):
        _fly(monitor, [10.0, 2.0, 1.0])
    assert monitor.result().halted is not None


def test_a_thousand_vehicles_cost_little() -> None:
    rng = np.random.default_rng(0)
    n = 1000
    pos = np.column_stack([rng.uniform(0, 1000, (n, 2)), np.full(n, 30.0)])
    monitor = SeparationMonitor(list(range(1, n + 1)), [3.0] * n)
    for t in range(20):
        monitor.observe(float(t), pos + t, np.ones(n, dtype=bool))
    report = monitor.result()
    # Checked against every one of the n(n-1)/2 distances.
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1)
    d[np.diag_indices(n)] = np.inf
    assert report.closest is not None
    assert report.closest.distance == pytest.approx(float(d.min()))
    assert len(report.breaches) == int(np.triu(d < 3.0, 1).sum()) > 0


def test_each_kind_has_a_separation_in_the_world() -> None:
    world = loads_world("[fixed_wing]\nseparation = 25.0\n[safety]\nfatal_separation = true\n")
    assert world.separations() == {"quadrotor": 3.0, "fixed_wing": 25.0}
    assert world.safety.fatal_separation
    with pytest.raises(WorldError, match=r"quadrotor\.separation"):
        loads_world("[quadrotor]\nseparation = 0\n")
    with pytest.raises(WorldError, match=r"safety\.fatal_separation"):
        loads_world('[safety]\nfatal_separation = "yes"\n')
    with pytest.raises(WorldError, match=r"safety\.ceiling"):
        loads_world("[safety]\nceiling = -5\n")
