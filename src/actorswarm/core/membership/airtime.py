"""What a shared radio channel allows (docs/collective-core.md, "Airtime"): the arithmetic
of a swarm of N platforms on a channel of ``CoreConfig.channel_bitrate`` bit/s, and the
log of platforms heard that a platform estimates N from before a view or roster tells it.

Pure functions of the configuration; every one returns the no-channel value (the 10 Hz
interval, 0 s) when ``channel_bitrate`` is None, so the core behaves as if this module did
not exist on a fast network.
"""

from __future__ import annotations

from actorswarm.core.config import CoreConfig

#: What one member's part of a new master's handshake puts on a shared channel, in
#: heartbeats' worth of bits: its report (about three), the acknowledgement, a sync when its
#: report is late, and a roster request.
HANDSHAKE_PACKETS = 6
#: On a shared channel, a platform counts the platforms it heard from within this many
#: seconds in its estimate of the swarm's size (what paces heartbeats and retransmissions
#: before a view or roster says more): long enough to span a boot, from the heartbeat every
#: platform broadcasts on starting to the first master's cadence reaching its members.
HEARD_HORIZON = 10.0


def member_cadence(config: CoreConfig, others: int) -> float:
    """The member heartbeat interval for ``others`` members: ``heartbeat_interval``, or
    slower when their heartbeats would take more than ``heartbeat_share`` of the channel."""
    if config.channel_bitrate is None:
        return config.heartbeat_interval
    load = max(others, 1) * config.heartbeat_bits
    return max(config.heartbeat_interval, load / (config.heartbeat_share * config.channel_bitrate))


def implied_size(config: CoreConfig, cadence: float) -> int:
    """How many members a master asking for ``cadence`` counts (:func:`member_cadence`
    inverted; 0 at the normal interval or without a channel)."""
    if config.channel_bitrate is None or cadence <= config.heartbeat_interval:
        return 0
    return int(cadence * (config.heartbeat_share * config.channel_bitrate) / config.heartbeat_bits)


def handshake_airtime(config: CoreConfig, members: int) -> float:
    """How long the packets a claim sets off take on the air: each of ``members`` reports,
    is acknowledged, may be sent a sync and heartbeats meanwhile — about
    :data:`HANDSHAKE_PACKETS` heartbeats' worth each, in the half of the channel the
    heartbeats leave. 0 without a channel."""
    if config.channel_bitrate is None:
        return 0.0
    bits = members * HANDSHAKE_PACKETS * config.heartbeat_bits
    return bits / ((1.0 - config.heartbeat_share) * config.channel_bitrate)


def channel_time(config: CoreConfig, size: int) -> float:
    """The time a swarm of ``size`` takes to put one packet each on the air (0 without a
    channel): what an acknowledgement may wait behind."""
    if config.channel_bitrate is None:
        return 0.0
    return size * config.heartbeat_bits / config.channel_bitrate


class HeardLog:
    """The platforms heard from lately (platform -> when), forgotten after
    :data:`HEARD_HORIZON`, swept at most once a second."""

    __slots__ = ("_heard", "_swept_at")

    def __init__(self, now: float) -> None:
        self._heard: dict[int, float] = {}
        self._swept_at = now

    def __len__(self) -> int:
        return len(self._heard)

    def heard(self, platform: int, now: float) -> None:
        self._heard[platform] = now

    def sweep(self, now: float) -> None:
        if now - self._swept_at < 1.0:
            return
        self._swept_at = now
        horizon = now - HEARD_HORIZON
        for peer in [p for p, t in self._heard.items() if t < horizon]:
            del self._heard[peer]
