"""Real daemons and the ground station on Zenoh's UDP multicast transport
(``--broadcast multicast``), on loopback: Linux carries a multicast group on ``lo`` given as
the interface, without root and without the interface's MULTICAST flag. A daemon alone on
its group says so; where no interface carries the default group, a daemon falls back to
the mesh and says that."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from actorswarm.cli.swarm_setup import zenoh_settings
from actorswarm.daemon.launch import LocalSwarm
from actorswarm.daemon.run import ALONE_S


def test_two_daemons_and_the_ground_station_meet_on_a_multicast_group(tmp_path: Path) -> None:
    # A port of this process's own: parallel runs on one host do not share a group.
    group = f"224.0.0.225:{20000 + (os.getpid() + 1) % 20000}"
    with LocalSwarm(tmp_path, 2, group=group, interface="lo") as swarm:
        assert swarm.endpoints == []
        # Alone on the group, the first says so once it has heard nothing for ALONE_S.
        swarm.start(1)
        swarm.wait("platform 1 saying it is alone", lambda: bool(swarm.events(1, "alone")),
                   timeout=ALONE_S + 10)  # fmt: skip
        (alone,) = swarm.events(1, "alone")
        assert alone["group"] == f"udp/{group}#iface=lo" and "--broadcast mesh" in alone["why"]
        swarm.start(2)
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
        assert started["fell_back"] is None
        status = swarm.gs("status", "--json", "--timeout", "5", timeout=30)
        assert status.returncode == 0, status.stdout + status.stderr
        heard = json.loads(status.stdout)
        assert {int(p) for p in heard["platforms"]} == {1, 2}, heard


def test_the_group_is_the_default_unless_the_mesh_is_asked_for() -> None:
    """A broadcast sent once by default; endpoints, scouting or relaying are the mesh's."""
    default = zenoh_settings(None, None, None)
    assert default.broadcast == "multicast" and default.fallback and not default.multicast
    for mesh in (
        zenoh_settings(["tcp/10.0.0.1:7447"], None, None),
        zenoh_settings(None, ["tcp/0.0.0.0:7447"], None),
        zenoh_settings(None, None, True),
        zenoh_settings(None, None, False),
        zenoh_settings(None, None, None, relay=True),
        zenoh_settings(None, None, None, "mesh"),
    ):
        assert mesh.broadcast == "mesh" and not mesh.fallback
    asked = zenoh_settings(None, None, False, "multicast")
    assert asked.broadcast == "multicast" and not asked.fallback
    # A group or interface named is meant: no falling back from it.
    assert not zenoh_settings(None, None, None, interface="wlan0").fallback
    assert not zenoh_settings(None, None, None, group="224.0.0.9:7000").fallback
    # --no-multicast: listed peers, for networks that drop multicast.
    assert zenoh_settings(None, None, False).broadcast == "mesh"


def test_without_a_multicast_interface_the_default_falls_back_to_the_mesh(
    tmp_path: Path,
) -> None:
    """A network namespace with nothing but loopback: no route carries the group. The
    daemon opens the mesh instead and says why; asked for the group, it refuses in one
    line."""
    if os.geteuid() != 0:
        pytest.skip("a network namespace of its own needs root (CAP_NET_ADMIN)")
    ns = f"aswmc{os.getpid()}"
    made = subprocess.run(["ip", "netns", "add", ns], capture_output=True, text=True, check=False)
    if made.returncode != 0:
        pytest.skip(f"network namespaces are unavailable here: {made.stderr.strip()}")
    try:
        subprocess.run(["ip", "-n", ns, "link", "set", "lo", "up"], check=True)
        daemon = [sys.executable, "-m", "actorswarm", "daemon", "--platform", "1", "--insecure",
                  "--state-dir", str(tmp_path / "s"), "--swarm", f"fb{os.getpid()}"]  # fmt: skip
        proc = subprocess.Popen(["ip", "netns", "exec", ns, *daemon], stderr=subprocess.PIPE,
                                text=True)  # fmt: skip
        assert proc.stderr is not None
        started: dict[str, object] = {}
        for line in proc.stderr:
            if '"started"' in line:
                started = json.loads(line)
                break
        proc.terminate()
        proc.communicate(timeout=15)
        assert started["broadcast"] == "mesh", started
        assert "No such device" in str(started["fell_back"]), started
        asked = subprocess.run(
            ["ip", "netns", "exec", ns, *daemon, "--broadcast", "multicast"],
            capture_output=True, text=True, timeout=30, check=False,
        )  # fmt: skip
        assert asked.returncode == 2, asked.stderr
        assert "cannot join the multicast group 224.0.0.225:7448: No such device" in asked.stderr
        assert "Traceback" not in asked.stderr
    finally:
        subprocess.run(["ip", "netns", "del", ns], check=False)


def test_a_group_on_an_interface_this_machine_lacks_is_refused_in_one_line() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "actorswarm", "gs", "status", "--interface", "nosuch0",
         "--insecure", "--timeout", "1"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert "cannot join the multicast group 224.0.0.225:7448 on interface nosuch0" in done.stderr
    assert "Traceback" not in done.stderr
