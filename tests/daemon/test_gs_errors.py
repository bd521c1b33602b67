"""A ground station whose packets the swarm refuses says so, and exits 1: one with another
signing key pair (the platforms count ``bad_signature``) and one with another swarm key
(both sides count ``bad_tag``). Real daemons over Zenoh on loopback."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest

from actorswarm.daemon.launch import LocalSwarm
from actorswarm.security import init_keys


@pytest.fixture
def swarm(tmp_path: Path) -> Iterator[LocalSwarm]:
    with LocalSwarm(tmp_path / "swarm", 2) as s:
        for p in (1, 2):
            s.start(p)
        s.wait("two daemons that agree on a master", lambda: s.agreed_master((1, 2)) is not None)
        yield s


def test_a_ground_station_with_a_foreign_key_is_told_its_commands_are_refused(
    swarm: LocalSwarm, tmp_path: Path
) -> None:
    # Another ground station's key pair, with the swarm's own swarm key: the platforms hear
    # it (the HMAC verifies) but refuse every signed packet.
    foreign = tmp_path / "foreign"
    init_keys(foreign)
    shutil.copy(swarm.keys / "swarm.key", foreign / "swarm.key")
    status = swarm.gs("status", "--timeout", "1.5", keys=foreign)
    assert status.returncode == 1, status.stdout + status.stderr
    # In a star swarm the ground station hears the master directly and the members through
    # the master's roster, which a refused ground station never gets: it hears the master.
    master = swarm.agreed_master((1, 2))
    assert f"{master} (master): no answer" in status.stdout
    assert f"no platform accepted the command: platform {master} heard but acknowledged " in (
        status.stderr
    )
    assert "bad_signature" in status.stderr
    swarm.wait(
        "the master counting the refused packets",
        lambda: bool(swarm.status(master).get("rejected", {}).get("bad_signature")),
    )
    fired = swarm.gs("event", "go", "--timeout", "1.5", keys=foreign)
    assert fired.returncode == 1
    assert f"{master}: FAILED: no answer" in fired.stdout and "bad_signature" in fired.stderr
    script = str(Path(__file__).with_name("three.xml"))
    state = ["--state", str(tmp_path / "gs.json")]
    deployed = swarm.gs("deploy", script, "--expect", "2", "--timeout", "1.5", *state, keys=foreign)
    assert deployed.returncode == 1
    member = 3 - master
    assert f"platform {master} heard but acknowledged nothing" in deployed.stderr
    assert f"platform {member} not heard: a star swarm's members are heard through" in (
        deployed.stderr
    )
    # The swarm's own ground station is answered, and exits 0.
    good = swarm.gs("status", "--timeout", "3")
    assert good.returncode == 0, good.stdout + good.stderr
    assert "no answer" not in good.stdout and good.stderr == ""


def test_a_ground_station_with_another_swarm_key_is_told_what_it_heard(
    swarm: LocalSwarm, tmp_path: Path
) -> None:
    other = tmp_path / "other"
    init_keys(other)
    status = swarm.gs("status", "--timeout", "1", keys=other)
    assert status.returncode == 1
    master = swarm.agreed_master((1, 2))
    assert f"of swarm {swarm.swarm!r} (from platform {master}, as they claim) under a " in (
        status.stderr
    )
    assert "different swarm key (bad_tag)" in status.stderr
    assert status.stdout == ""  # nothing verified: no platform is shown
