"""How distance degrades the radio: a pure model, from positions to loss and latency.

Theory of operation
-------------------
The simulated radio (:class:`~actorswarm.sim.radio.SimRadio`) decides each packet's fate
from a loss probability and a latency. Driven by the world, those come from where sender
and receiver are, through this model (parameters in
:class:`~actorswarm.world.config.RadioConfig`), with ``d`` the 3-D distance in metres:

* **Loss.** ``loss_at_range * (d / range) ** loss_exponent`` within ``range``, and 1 beyond
  it. It is 0 at d = 0 and grows monotonically with distance; a large exponent keeps links
  near-perfect over most of the range and lets them fall off steeply near its edge, as a
  real link's packet error rate does once the signal nears the receiver's sensitivity.
* **Latency.** ``base_latency + latency_per_km * d / 1000`` seconds: a fixed cost (queueing,
  MAC access, processing) plus a part that grows with distance, standing for the lower data
  rates and retries of a long link (propagation alone, 3.3 µs/km, is negligible).
* **Jitter** is not computed here: the radio draws it per packet, in ``[0, jitter]``, from
  its own seeded generator, so this model stays a pure function.
* **Relaying** (``relay``, the daemons' ``--relay``): a packet reaches a platform out of
  range through others. :func:`routes` picks, for every pair, the path of fewest expected
  transmissions (ETX: the sum over its links of ``1 / (1 - loss)``, the metric of mesh
  radios' routing; Zenoh routes by hop count over links that TCP makes reliable, which
  differs only where a short hop is much better than a long one). Along that path the losses
  compound (``1 - Π(1 - loss_i)``: each hop draws its own), the latencies add up, and each
  relay adds ``relay_latency`` (taking a packet in and sending it on). One draw per
  receiver, so two receivers behind one relay lose a packet independently: a
  simplification. On the air, each relay sends a packet on once more: a unicast costs one
  transmission per link of its path, a broadcast one per platform that forwards it (the
  distinct relays of its routes, :attr:`Routes.forwarders`), as a mesh radio's flood or a
  multicast forward would; links made of unicasts (the daemons' TCP) cost more.
  :func:`hops` counts the links of the fewest-hop path, for the span a swarm reaches.

Every function is pure (no state, no randomness, no clock) and works on numpy arrays:
positions of shape ``(..., 3)`` broadcast against each other, so one call can answer for
one pair, for one sender and all receivers, or for the whole swarm (:func:`link_matrix`).
A link is symmetric: the model depends only on the distance.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from actorswarm.world.config import RadioConfig

__all__ = [
    "Routes",
    "distances",
    "hop_span",
    "hops",
    "latency_at",
    "link",
    "link_arrays",
    "link_matrix",
    "loss_at",
    "reachable",
    "routes",
]

FloatArray = NDArray[np.float64]
Position = Sequence[float]


@overload
def loss_at(distance: float, cfg: RadioConfig) -> float: ...
@overload
def loss_at(distance: FloatArray, cfg: RadioConfig) -> FloatArray: ...
def loss_at(distance: float | FloatArray, cfg: RadioConfig) -> float | FloatArray:
    """The probability that a packet is lost over ``distance`` metres (elementwise)."""
    d = np.asarray(distance, dtype=np.float64)
    within = np.minimum(cfg.loss_at_range * (d / cfg.range) ** cfg.loss_exponent, 1.0)
    loss = np.where(d > cfg.range, 1.0, within)
    return float(loss) if loss.ndim == 0 else loss


@overload
def latency_at(distance: float, cfg: RadioConfig) -> float: ...
@overload
def latency_at(distance: FloatArray, cfg: RadioConfig) -> FloatArray: ...
def latency_at(distance: float | FloatArray, cfg: RadioConfig) -> float | FloatArray:
    """The one-way latency, seconds, over ``distance`` metres (elementwise; before jitter)."""
    d = np.asarray(distance, dtype=np.float64)
    latency = cfg.base_latency + cfg.latency_per_km * d / 1000.0
    return float(latency) if latency.ndim == 0 else latency


def link(a_pos: Position, b_pos: Position, cfg: RadioConfig) -> tuple[float, float]:
    """``(loss_probability, latency_s)`` of the link between two points ``(x, y, z)``."""
    d = float(np.linalg.norm(np.asarray(a_pos, dtype=np.float64) - np.asarray(b_pos)))
    return loss_at(d, cfg), latency_at(d, cfg)


def link_arrays(
    a_pos: ArrayLike, b_pos: ArrayLike, cfg: RadioConfig
) -> tuple[FloatArray, FloatArray]:
    """:func:`link` for arrays of points, shape ``(..., 3)``, broadcast against each other:
    loss and latency arrays of the broadcast shape without its last axis."""
    delta = np.asarray(a_pos, dtype=np.float64) - np.asarray(b_pos, dtype=np.float64)
    d = np.asarray(np.linalg.norm(delta, axis=-1), dtype=np.float64)
    return (
        np.asarray(loss_at(d, cfg), dtype=np.float64),
        np.asarray(latency_at(d, cfg), dtype=np.float64),
    )


def distances(positions: ArrayLike) -> FloatArray:
    """``(n, n)`` distances between the ``n`` points of an ``(n, 3)`` array."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    out: FloatArray = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    return out


def link_matrix(positions: ArrayLike, cfg: RadioConfig) -> tuple[FloatArray, FloatArray]:
    """``(loss, latency)``, each ``(n, n)``, between every pair of the ``n`` points (rows
    send, columns receive; both are symmetric). The diagonal is a platform talking to
    itself: loss 0, latency ``base_latency``."""
    d = distances(positions)
    return loss_at(d, cfg), latency_at(d, cfg)


def reachable(positions: ArrayLike, cfg: RadioConfig) -> NDArray[np.bool_]:
    """``(n, n)``: True where two of the ``n`` points can hear each other at all (within
    ``range``, loss below 1). The diagonal is True."""
    d = distances(positions)
    out: NDArray[np.bool_] = loss_at(d, cfg) < 1.0
    np.fill_diagonal(out, True)
    return out


class Routes(NamedTuple):
    """The relayed paths between every pair of ``n`` platforms (:func:`routes`): ``loss``,
    ``latency`` and ``hops`` ``(n, n)`` as :func:`routes` says; ``forwarders`` ``(n,)``:
    how many platforms send on a broadcast from each (the distinct relays of its routes to
    every platform it reaches), the extra transmissions it costs the air."""

    loss: FloatArray
    latency: FloatArray
    hops: NDArray[np.int64]
    forwarders: NDArray[np.int64]


def routes(loss: FloatArray, latency: FloatArray, relay_latency: float) -> Routes:
    """The relayed paths between every pair of ``n`` platforms whose direct links have
    ``loss`` and ``latency`` (rows send; see the module's docstring): the path of fewest
    expected transmissions, its compound loss (1 where no path exists), its latency plus
    ``relay_latency`` per relay, its links (0 on the diagonal, -1 where no path exists),
    and each sender's forwarders (:class:`Routes`). Floyd–Warshall over numpy rows, with
    each path's last relay kept (a sender's paths form a tree: its forwarders are the last
    relays before the platforms two or more links away): O(n³), about 1 ms at 30
    platforms and a second at 1000."""
    n = len(loss)
    ok = loss < 1.0
    with np.errstate(divide="ignore"):
        cost = np.where(ok, 1.0 / np.where(ok, 1.0 - loss, 1.0), np.inf)
        keep = np.where(ok, np.log(np.where(ok, 1.0 - loss, 1.0)), -np.inf)
    lat = np.where(ok, latency, 0.0)
    count = np.where(ok, 1, 0).astype(np.int64)
    # The platform before the last link of each path: the sender itself on a direct link.
    last = np.repeat(np.arange(n, dtype=np.int64)[:, None], n, axis=1)
    np.fill_diagonal(cost, 0.0)
    np.fill_diagonal(keep, 0.0)
    np.fill_diagonal(lat, 0.0)
    np.fill_diagonal(count, 0)
    for k in range(n):
        through = cost[:, k, None] + cost[None, k, :]
        better = through < cost
        if not better.any():
            continue
        cost = np.where(better, through, cost)
        keep = np.where(better, keep[:, k, None] + keep[None, k, :], keep)
        lat = np.where(better, lat[:, k, None] + lat[None, k, :] + relay_latency, lat)
        count = np.where(better, count[:, k, None] + count[None, k, :], count)
        last = np.where(better, last[None, k, :], last)
    reached = np.isfinite(cost)
    out_loss: FloatArray = np.where(reached, 1.0 - np.exp(keep), 1.0)
    out_hops: NDArray[np.int64] = np.where(reached, count, -1)
    relayed = out_hops >= 2
    forwards = np.zeros((n, n), dtype=bool)
    senders, _ = np.nonzero(relayed)
    forwards[senders, last[relayed]] = True
    forwarders: NDArray[np.int64] = forwards.sum(axis=1).astype(np.int64)
    return Routes(out_loss, lat, out_hops, forwarders)


def hops(can_hear: NDArray[np.bool_]) -> NDArray[np.int64]:
    """``(n, n)``: the fewest links between every pair, given which pairs hear each other
    directly (:func:`reachable`); 0 on the diagonal, -1 where no path exists."""
    n = len(can_hear)
    adjacency = np.asarray(can_hear, dtype=np.float32)
    np.fill_diagonal(adjacency, 0.0)
    out = np.full((n, n), -1, dtype=np.int64)
    np.fill_diagonal(out, 0)
    frontier = np.eye(n, dtype=np.float32)
    for step in range(1, n):
        frontier = ((frontier @ adjacency) > 0).astype(np.float32)
        new = (frontier > 0) & (out < 0)
        if not new.any():
            break
        out[new] = step
        frontier = new.astype(np.float32)
    return out


def hop_span(positions: ArrayLike, cfg: RadioConfig) -> tuple[int, int]:
    """``(span, groups)`` of platforms at ``positions``: the most links any two of them
    are apart within a group that hears itself hop by hop, and how many such groups there
    are (1: one swarm; more: out of radio range of each other even through relays)."""
    table = hops(reachable(positions, cfg))
    if not len(table):
        return 0, 0
    seen: set[int] = set()
    groups = 0
    for i in range(len(table)):
        if i in seen:
            continue
        groups += 1
        seen.update(np.flatnonzero(table[i] >= 0).tolist())
    return int(table.max()), groups
