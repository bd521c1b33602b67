"""The Zenoh transport on its own: peers found by multicast scouting alone, and a swarm on
Zenoh's UDP multicast transport (on loopback, which needs no root)."""

from __future__ import annotations

import json
import os
import time

import pytest

from actorswarm.transport import ZenohSettings, ZenohTransport


def test_peers_without_endpoints_find_each_other_by_multicast_scouting() -> None:
    """No ``listen`` and no ``connect``: each peer keeps Zenoh's default listener, which
    scouting advertises (an empty listener list would leave it unreachable)."""
    got: list[bytes] = []
    settings = ZenohSettings(multicast=True)
    swarm = f"scout{os.getpid()}"
    with (
        ZenohTransport(swarm, 1, settings) as receiver,
        ZenohTransport(swarm, 2, settings) as sender,
    ):
        end = time.monotonic() + 15
        while not got and time.monotonic() < end:
            sender.send(None, b"hello")
            time.sleep(0.1)
            got += receiver.drain(100)
    assert got and got[0] == b"hello"


def _group() -> str:
    """A group port of this process's own, so parallel runs do not hear each other."""
    return f"224.0.0.225:{20000 + os.getpid() % 20000}"


def test_broadcasts_and_unicasts_travel_on_a_multicast_group() -> None:
    """``broadcast="multicast"`` on loopback: no endpoint, no scouting, only the group; a
    broadcast reaches every other member, a unicast only its addressee, nothing reaches
    its sender, and no member holds a unicast session."""
    settings = ZenohSettings(multicast=False, broadcast="multicast", group=_group(), interface="lo")
    swarm = f"air{os.getpid()}"
    with (
        ZenohTransport(swarm, 1, settings) as one,
        ZenohTransport(swarm, 2, settings) as two,
        ZenohTransport(swarm, 3, settings) as three,
    ):
        got: dict[int, list[bytes]] = {1: [], 2: [], 3: []}
        members = {1: one, 2: two, 3: three}
        end = time.monotonic() + 15
        # Members meet when their first join reaches the others: repeat until they have.
        while time.monotonic() < end and not (got[2] and got[3]):
            one.send(None, b"all")
            time.sleep(0.1)
            for p, t in members.items():
                got[p] += t.drain(100)
        assert got[1] == [] and set(got[2]) == {b"all"} and set(got[3]) == {b"all"}
        for t in members.values():
            got[t.platform].clear()
        one.send(2, b"to two")
        time.sleep(0.5)
        for p, t in members.items():
            got[p] += t.drain(100)
        assert got == {1: [], 2: [b"to two"], 3: []}
        session = one._session
        assert session is not None and list(session.info.peers_zid()) == []


def test_multicast_settings_refuse_what_would_loop_or_cannot_be_a_group() -> None:
    with pytest.raises(ValueError, match="connect endpoints"):
        ZenohSettings(multicast=False, broadcast="multicast", connect=("tcp/127.0.0.1:7447",))
    with pytest.raises(ValueError, match="multicast scouting"):
        ZenohSettings(broadcast="multicast")
    with pytest.raises(ValueError, match=r"broadcast 'radio'.*mesh or multicast"):
        ZenohSettings(broadcast="radio")
    with pytest.raises(ValueError, match=r"10\.0\.0\.1 is not a multicast address"):
        ZenohSettings(multicast=False, broadcast="multicast", group="10.0.0.1:7448")
    with pytest.raises(ValueError, match="ADDRESS:PORT"):
        ZenohSettings(multicast=False, broadcast="multicast", group="224.0.0.225")
    with pytest.raises(ValueError, match="port 70000"):
        ZenohSettings(multicast=False, broadcast="multicast", group="224.0.0.225:70000")
    with pytest.raises(ValueError, match="interface 'eth0#x'"):
        ZenohSettings(multicast=False, broadcast="multicast", interface="eth0#x")
    with pytest.raises(ValueError, match="lease 10 ms"):
        ZenohSettings(lease_ms=10)
    ipv6 = ZenohSettings(multicast=False, broadcast="multicast", group="[ff02::1]:7448")
    assert ipv6.group_endpoint == "udp/[ff02::1]:7448"


def test_multicast_members_join_often_and_within_their_lease() -> None:
    """Zenoh's default join interval (2.5 s) is longer than a short lease (members would
    expire between joins) and than a ground-station command listens: 250 ms, and at least
    four joins per lease."""
    cfg = ZenohSettings(
        multicast=False, broadcast="multicast", lease_ms=2000, interface="wlan0"
    ).config()
    data = json.loads(str(cfg))
    assert data["transport"]["multicast"]["join_interval"] == 250
    assert data["transport"]["link"]["tx"]["lease"] == 2000
    assert data["listen"]["endpoints"] == ["udp/224.0.0.225:7448#iface=wlan0"]
    assert data["scouting"]["multicast"]["enabled"] is False
    short = ZenohSettings(multicast=False, broadcast="multicast", lease_ms=400).config()
    assert json.loads(str(short))["transport"]["multicast"]["join_interval"] == 100
