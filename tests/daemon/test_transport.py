"""The Zenoh transport on its own: peers found by multicast scouting alone, and a swarm on
Zenoh's UDP multicast transport (on loopback, which needs no root)."""

from __future__ import annotations

import json
import os
import time

import pytest
import zenoh

from actorswarm.transport import ZenohSettings, ZenohTransport
from actorswarm.transport.zenoh_transport import SPREAD_CHUNKS, SPREAD_PATTERNS, spread_pattern


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
    """``broadcast="multicast"`` on loopback, four members: no endpoint, no scouting, only
    the group; every broadcast reaches every other member once, a unicast only its
    addressee, nothing reaches its sender, and no member holds a unicast session. (Four
    members subscribing to one shared key flood the group in Zenoh 1.10 and lose data: see
    the transport's docstring.)"""
    settings = ZenohSettings(multicast=False, broadcast="multicast", group=_group(), interface="lo")
    swarm = f"air{os.getpid()}"
    with (
        ZenohTransport(swarm, 1, settings) as one,
        ZenohTransport(swarm, 2, settings) as two,
        ZenohTransport(swarm, 3, settings) as three,
        ZenohTransport(swarm, 4, settings) as four,
    ):
        members = {1: one, 2: two, 3: three, 4: four}
        got: dict[int, list[bytes]] = {p: [] for p in members}
        end = time.monotonic() + 15
        # Members meet when their first join reaches the others: repeat until they have.
        while time.monotonic() < end and not all(got[p] for p in (2, 3, 4)):
            one.send(None, b"hello")
            time.sleep(0.1)
            for p, t in members.items():
                got[p] += t.drain(100)
        assert got[1] == [] and all(set(got[p]) == {b"hello"} for p in (2, 3, 4)), got
        time.sleep(0.3)
        for t in members.values():
            t.drain(100)
        got = {p: [] for p in members}
        sent = [b"n%d" % i for i in range(30)]
        for data in sent:
            one.send(None, data)
            time.sleep(0.01)
        one.send(2, b"to two")
        time.sleep(0.5)
        for p, t in members.items():
            got[p] += t.drain(100)
        assert got[1] == []
        assert got[2] == [b"to two", *sent]  # unicasts are drained first
        assert got[3] == sent and got[4] == sent
        session = one._session
        assert session is not None and list(session.info.peers_zid()) == []


def test_every_member_matches_the_tail_with_a_pattern_of_its_own() -> None:
    tail = zenoh.KeyExpr("k/" + "/".join(["mmmm"] * SPREAD_CHUNKS))
    indices = [0, 1, 14, 15, 224, 225, 65535, 65536, SPREAD_PATTERNS - 1]
    patterns = [spread_pattern(i) for i in indices]
    assert len(set(patterns)) == len(indices)
    for pattern in patterns:
        assert zenoh.KeyExpr(f"k/{pattern}").includes(tail), pattern
    # Every digit of every chunk: 15 patterns of "mmmm", all different, all matching it.
    chunks = {spread_pattern(d).split("/")[0] for d in range(15)}
    assert len(chunks) == 15 and all(
        zenoh.KeyExpr(c).includes(zenoh.KeyExpr("mmmm")) for c in chunks
    )
    with pytest.raises(ValueError, match="spread pattern"):
        spread_pattern(SPREAD_PATTERNS)


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
