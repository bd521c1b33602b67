"""The Zenoh transport on its own: peers found by multicast scouting alone."""

from __future__ import annotations

import os
import time

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
