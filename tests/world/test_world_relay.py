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
    routed, delay, count, _ = routes(loss, latency, 0.002)
    assert count[0].tolist() == [0, 1, 2, 3, 4]
    # Every hop draws its own loss; every relay adds its latency to the hops'.
    assert routed[0, 4] == pytest.approx(1 - (1 - step) ** 4)
    assert delay[0, 4] == pytest.approx(4 * 0.005 + 3 * 0.002)
    assert np.allclose(routed, routed.T) and np.allclose(delay, delay.T)


def test_a_route_prefers_two_clean_hops_to_one_lossy_link() -> None:
    """The fewest expected transmissions: 1/(1-0.8) = 5 direct against 2 relayed."""
    loss = np.array([[0.0, 0.0, 0.8], [0.0, 0.0, 0.0], [0.8, 0.0, 0.0]])
    latency = np.full((3, 3), 0.005)
    routed, delay, count, _ = routes(loss, latency, 0.001)
    assert count[0, 2] == 2 and routed[0, 2] == 0.0 and delay[0, 2] == pytest.approx(0.011)
    # A slightly lossy direct link beats two hops.
    loss[0, 2] = loss[2, 0] = 0.3
    routed, _, count, _ = routes(loss, latency, 0.001)
    assert count[0, 2] == 1 and routed[0, 2] == pytest.approx(0.3)


def test_platforms_out_of_reach_even_by_relays_have_no_route() -> None:
    two_groups = np.vstack([LINE[:2], LINE[:2] + np.array([1000.0, 0.0, 0.0])])
    loss, latency = link_matrix(two_groups, CFG)
    routed, _, count, _ = routes(loss, latency, 0.002)
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


def test_a_broadcast_is_sent_on_by_each_relay_of_its_routes_once() -> None:
    """A line of five: from an end, 2, 3 and 4 send it on; from the middle, 2 and 4; on a
    3x3 grid (links only along rows and columns), the relays of one tree of routes."""
    loss, latency = link_matrix(LINE, CFG)
    assert routes(loss, latency, 0.002).forwarders.tolist() == [3, 2, 2, 2, 3]
    grid = np.array([[90.0 * i, 90.0 * j, 0.0] for i in range(3) for j in range(3)])
    loss, latency = link_matrix(grid, CFG)
    table = routes(loss, latency, 0.002)
    # The corner reaches 8 platforms, 6 through relays. Their routes tie (every link is
    # alike), so which tree carries them is the route search's choice: any has at least
    # 4 forwarders ({2, 4, 5, 6} with the corner at 1) and at most the 7 platforms with
    # someone beyond them.
    assert table.hops[0].tolist() == [0, 1, 2, 1, 2, 3, 2, 3, 4]
    assert 4 <= table.forwarders[0] <= 7
    # The centre hears its four neighbours and reaches each corner through one of two.
    assert 2 <= table.forwarders[4] <= 4
    # Two groups out of each other's reach: nobody forwards between them.
    apart = np.vstack([LINE[:2], LINE[:2] + np.array([1000.0, 0.0, 0.0])])
    loss, latency = link_matrix(apart, CFG)
    assert routes(loss, latency, 0.002).forwarders.tolist() == [0, 0, 0, 0]


def test_the_world_says_how_often_relays_send_a_packet_on() -> None:
    plain = World(loads_world(WORLD.format(relay="false")), range(1, 6))
    relayed = World(loads_world(WORLD.format(relay="true")), range(1, 6))
    assert [plain.relays(1, 5), plain.relays(1, None)] == [0, 0]
    # 1 to 5 is four links: three relays send it on; a broadcast from 1 is sent on by 2-4.
    assert [relayed.relays(1, 5), relayed.relays(1, 2), relayed.relays(1, None)] == [3, 0, 3]
    assert relayed.relays(3, None) == 2
    for world in (plain, relayed):
        with pytest.raises(KeyError, match="9"):
            world.relays(9, None)
        with pytest.raises(KeyError, match="9"):
            world.relays(1, 9)
