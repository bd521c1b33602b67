"""Relaying in the radio model: routes, hop counts, spans, and the world's relayed links."""

from __future__ import annotations

import numpy as np
import pytest

from actorswarm.world import RadioConfig
from actorswarm.world.config import WorldError, loads_world
from actorswarm.world.radio_model import hop_span, hops, link_matrix, reachable, routes
from actorswarm.world.world import ROUTE_INTERVAL, World

CFG = RadioConfig(range=100.0, loss_at_range=0.2, loss_exponent=2.0, base_latency=0.005,
                  latency_per_km=0.0, jitter=0.0)  # fmt: skip
#: Five platforms on a line, 90 m apart: each hears only the ones beside it.
LINE = np.array([[90.0 * i, 0.0, 0.0] for i in range(5)])


def test_a_chain_is_relayed_hop_by_hop_with_its_losses_compounded() -> None:
    loss, latency = link_matrix(LINE, CFG)
    assert loss[0, 2] == 1.0  # out of range directly
    step = 0.2 * 0.9**2  # each 90 m hop
    assert loss[0, 1] == pytest.approx(step)
    routed, delay, count = routes(loss, latency, 0.002)
    assert count[0].tolist() == [0, 1, 2, 3, 4]
    # Every hop draws its own loss; every relay adds its latency to the hops'.
    assert routed[0, 4] == pytest.approx(1 - (1 - step) ** 4)
    assert delay[0, 4] == pytest.approx(4 * 0.005 + 3 * 0.002)
    assert np.allclose(routed, routed.T) and np.allclose(delay, delay.T)


def test_a_route_prefers_two_clean_hops_to_one_lossy_link() -> None:
    """The fewest expected transmissions: 1/(1-0.8) = 5 direct against 2 relayed."""
    loss = np.array([[0.0, 0.0, 0.8], [0.0, 0.0, 0.0], [0.8, 0.0, 0.0]])
    latency = np.full((3, 3), 0.005)
    routed, delay, count = routes(loss, latency, 0.001)
    assert count[0, 2] == 2 and routed[0, 2] == 0.0 and delay[0, 2] == pytest.approx(0.011)
    # A slightly lossy direct link beats two hops.
    loss[0, 2] = loss[2, 0] = 0.3
    routed, _, count = routes(loss, latency, 0.001)
    assert count[0, 2] == 1 and routed[0, 2] == pytest.approx(0.3)


def test_platforms_out_of_reach_even_by_relays_have_no_route() -> None:
    two_groups = np.vstack([LINE[:2], LINE[:2] + np.array([1000.0, 0.0, 0.0])])
    loss, latency = link_matrix(two_groups, CFG)
    routed, _, count = routes(loss, latency, 0.002)
    assert routed[0, 2] == 1.0 and count[0, 2] == -1 and count[0, 1] == 1
    assert hop_span(two_groups, CFG) == (1, 2)
    assert hop_span(LINE, CFG) == (4, 1)
    assert hop_span(LINE[:1], CFG) == (0, 1)
    table = hops(reachable(LINE, CFG))
    assert table[0].tolist() == [0, 1, 2, 3, 4] and table[2].tolist() == [2, 1, 0, 1, 2]


WORLD = """
[world]
step = 0.1
[fleet]
kind = "quadrotor"
spacing = 90.0
columns = 5
[radio]
range = 100.0
loss_at_range = 0.2
relay = {relay}
"""


def test_the_world_answers_for_the_relayed_path_only_when_its_radio_relays() -> None:
    plain = World(loads_world(WORLD.format(relay="false")), range(1, 6))
    relayed = World(loads_world(WORLD.format(relay="true")), range(1, 6))
    assert plain.link(1, 5)[0] == 1.0
    loss, latency = relayed.link(1, 5)
    assert 0.0 < loss < 1.0 and latency == pytest.approx(4 * 0.005 + 3 * 0.002 + 0.36 * 0.001)
    assert relayed.hop_span() == plain.hop_span() == (4, 1)
    # Routes follow the vehicles every ROUTE_INTERVAL, not every step.
    assert relayed.step <= ROUTE_INTERVAL


def test_relay_must_be_true_or_false() -> None:
    with pytest.raises(WorldError, match="relay"):
        loads_world(WORLD.format(relay='"yes"'))
    with pytest.raises(WorldError, match="relay_latency"):
        loads_world(WORLD.format(relay="true") + "relay_latency = -1\n")
