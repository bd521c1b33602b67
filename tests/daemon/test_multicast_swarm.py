"""Two real daemons and the ground station on Zenoh's UDP multicast transport
(``--broadcast multicast``), on loopback: Linux carries a multicast group on ``lo`` given as
the interface, without root and without the interface's MULTICAST flag."""

from __future__ import annotations

import json
import os
from pathlib import Path

from actorswarm.daemon.launch import LocalSwarm


def test_two_daemons_and_the_ground_station_meet_on_a_multicast_group(tmp_path: Path) -> None:
    # A port of this process's own: parallel runs on one host do not share a group.
    group = f"224.0.0.225:{20000 + (os.getpid() + 1) % 20000}"
    with LocalSwarm(tmp_path, 2, group=group, interface="lo") as swarm:
        assert swarm.endpoints == []
        swarm.start_all()
        swarm.wait(
            "both daemons see each other and follow one master",
            lambda: (
                swarm.agreed_master((1, 2)) is not None
                and all(len(swarm.status(p).get("members", ())) == 1 for p in (1, 2))
            ),
            timeout=30,
        )
        started = swarm.events(1, "started")[-1]
        assert started["broadcast"] == f"udp/{group}#iface=lo", started
        status = swarm.gs("status", "--json", "--timeout", "5", timeout=30)
        assert status.returncode == 0, status.stdout + status.stderr
        heard = json.loads(status.stdout)
        assert {int(p) for p in heard["platforms"]} == {1, 2}, heard
