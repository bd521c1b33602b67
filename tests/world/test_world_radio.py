"""The radio's distance model: monotone loss, certain loss beyond range, linear latency."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from actorswarm.world import RadioConfig
from actorswarm.world.radio_model import (
    distances,
    latency_at,
    link,
    link_arrays,
    link_matrix,
    loss_at,
    reachable,
)

CFG = RadioConfig(
    range=1000.0,
    loss_at_range=0.3,
    loss_exponent=2.0,
    base_latency=0.01,
    latency_per_km=0.004,
)


def test_loss_grows_with_distance_and_is_certain_beyond_range() -> None:
    d = np.linspace(0.0, 2000.0, 2001)
    loss = loss_at(d, CFG)
    assert loss[0] == 0.0
    assert np.all(np.diff(loss) >= 0.0)
    assert loss_at(500.0, CFG) == pytest.approx(0.3 * 0.25)
    assert loss_at(1000.0, CFG) == pytest.approx(0.3)
    assert loss_at(1000.001, CFG) == 1.0
    assert np.all(loss[d > 1000.0] == 1.0)
    assert np.all((loss >= 0.0) & (loss <= 1.0))


def test_latency_is_base_plus_per_km() -> None:
    assert latency_at(0.0, CFG) == pytest.approx(0.01)
    assert latency_at(1500.0, CFG) == pytest.approx(0.016)
    assert np.all(np.diff(latency_at(np.linspace(0, 5000, 50), CFG)) > 0)


@given(
    a=st.tuples(*[st.floats(-3000, 3000)] * 3),
    b=st.tuples(*[st.floats(-3000, 3000)] * 3),
    exponent=st.floats(0.1, 8.0),
    at_range=st.floats(0.0, 1.0),
)
def test_link_is_symmetric_and_a_probability(
    a: tuple[float, float, float],
    b: tuple[float, float, float],
    exponent: float,
    at_range: float,
) -> None:
    cfg = RadioConfig(range=1500.0, loss_at_range=at_range, loss_exponent=exponent)
    loss, latency = link(a, b, cfg)
    assert (loss, latency) == link(b, a, cfg)
    assert 0.0 <= loss <= 1.0 and latency >= cfg.base_latency
    d = math.dist(a, b)
    if d > cfg.range:
        assert loss == 1.0
    # Farther never loses less.
    far = (b[0] + 10.0 * (b[0] - a[0]), b[1] + 10.0 * (b[1] - a[1]), b[2] + 10.0 * (b[2] - a[2]))
    assert link(a, far, cfg)[0] >= loss


def test_arrays_broadcast_and_match_the_scalar_model() -> None:
    sender = np.array([0.0, 0.0, 100.0])
    receivers = np.array([[300.0, 400.0, 100.0], [0.0, 0.0, 0.0], [2000.0, 0.0, 100.0]])
    loss, latency = link_arrays(sender, receivers, CFG)
    assert loss.shape == latency.shape == (3,)
    for i, r in enumerate(receivers):
        assert (loss[i], latency[i]) == pytest.approx(link(tuple(sender), tuple(r), CFG))
    assert loss[0] == pytest.approx(0.3 * 0.25) and loss[2] == 1.0


def test_matrices_for_a_swarm() -> None:
    positions = np.array([[0.0, 0.0, 0.0], [600.0, 0.0, 0.0], [1200.0, 0.0, 0.0]])
    d = distances(positions)
    assert d == pytest.approx(np.array([[0, 600, 1200], [600, 0, 600], [1200, 600, 0]]))
    loss, latency = link_matrix(positions, CFG)
    assert np.array_equal(loss, loss.T) and np.array_equal(latency, latency.T)
    assert np.diag(loss).tolist() == [0.0, 0.0, 0.0]
    assert loss[0, 2] == 1.0 and loss[0, 1] == pytest.approx(0.3 * 0.36)
    assert reachable(positions, CFG).tolist() == [
        [True, True, False],
        [True, True, True],
        [False, True, True],
    ]


def test_full_loss_at_range_makes_the_edge_unreachable() -> None:
    cfg = RadioConfig(range=100.0, loss_at_range=1.0)
    assert reachable([[0, 0, 0], [100, 0, 0]], cfg).tolist() == [[True, False], [False, True]]
