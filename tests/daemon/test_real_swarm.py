"""A real swarm on this machine: daemon processes over Zenoh on loopback, driven by the
``gs`` commands as an operator would (each step bounded in time)."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from actorswarm.daemon.launch import LocalSwarm
from actorswarm.daemon.state import StateDir

SCRIPT = Path(__file__).with_name("three.xml")


@pytest.fixture
def swarm(tmp_path: Path) -> Iterator[LocalSwarm]:
    with LocalSwarm(tmp_path, 3) as s:
        yield s


def test_three_daemons_are_deployed_started_and_switched_by_the_ground_station(
    swarm: LocalSwarm, tmp_path: Path
) -> None:
    for p in (1, 2, 3):
        swarm.start(p)
    swarm.wait(
        "three daemons that agree on a master",
        lambda: swarm.agreed_master((1, 2, 3)) is not None,
    )
    master = swarm.agreed_master((1, 2, 3))
    script = SCRIPT
    state = ["--state", str(tmp_path / "gs.json")]
    deployed = swarm.gs("deploy", str(script), "--expect", "3", *state)
    assert deployed.returncode == 0, deployed.stderr
    assert "confirmed by 3 of 3: [1, 2, 3]" in deployed.stdout
    asked = time.time()
    started = swarm.gs("start", *state)
    assert started.returncode == 0, started.stderr
    assert "started on 3 of 3" in started.stdout
    assert "the task's clock began at " in started.stdout
    # Each kept the task's start on the shared clock (here the one host's UTC clock), to go
    # on in that task after a restart: the same instant for all three.
    began = {StateDir(swarm.state_dir(p)).began() for p in (1, 2, 3)}
    assert len(began) == 1 and asked <= began.pop() <= time.time(), began
    fired = swarm.gs("event", "go_event")
    assert fired.returncode == 0, fired.stdout + fired.stderr
    assert fired.stdout.count("event go_event delivered") == 3
    swarm.wait(
        "every platform in B",
        lambda: all(swarm.status(p).get("actors") == ["B"] for p in (1, 2, 3)),
    )
    status = swarm.gs("status", "--json")
    assert status.returncode == 0, status.stderr
    platforms = json.loads(status.stdout)["platforms"]
    assert set(platforms) == {"1", "2", "3"}
    # The task's clock as each answered: one instant, and clocks that agree (one machine).
    assert {row["began"] for row in platforms.values()} == {StateDir(swarm.state_dir(1)).began()}
    assert all(
        abs(row["clock_offset_s"]) <= 0.25 + row["clock_uncertainty_s"]
        for row in platforms.values()
    ), platforms
    said = swarm.gs("status")
    assert "the task's clock began at " in said.stdout and "on 3 platform(s)" in said.stdout
    assert "warning" not in said.stderr, said.stderr
    assert {p: row["actors"] for p, row in platforms.items()} == {p: ["B"] for p in "123"}
    assert [p for p, row in platforms.items() if row["master"]] == [str(master)]
    assert {row["incarnation"] for row in platforms.values()} == {0}
    assert {p: row["roles"] for p, row in platforms.items()} == {p: [] for p in "123"}
    # Every packet taken in went through the pipeline, in batches of one wake each.
    for p in (1, 2, 3):
        meters = swarm.status(p)
        receive = meters["receive"]
        assert set(receive) == {
            "batches", "packets", "largest_batch", "cut_batches", "bursts", "ring_full"
        }  # fmt: skip
        assert receive["packets"] == meters["traffic"]["recv_packets"] > 0
        assert 0 < receive["batches"] <= receive["packets"]
        assert receive["largest_batch"] >= 1
    # They verified the operator's signed commands with libsodium, without the cryptography
    # package and without OpenSSL: neither is mapped into any of them (asyncio's ssl is
    # deferred, HMAC-SHA256 is the interpreter's own).
    for p in (1, 2, 3):
        maps = Path(f"/proc/{swarm.procs[p].pid}/maps").read_text()
        assert "/nacl/_sodium" in maps
        assert "/cryptography/" not in maps
        assert "libcrypto.so" not in maps and "libssl.so" not in maps
    # Zenoh carried all of it in its application pool: its other pools (threads rx-0,
    # tx-0, acc-0, net-0 when they run) were handed over to it.
    for p in (1, 2, 3):
        tasks = Path(f"/proc/{swarm.procs[p].pid}/task")
        names = {(task / "comm").read_text().strip() for task in tasks.iterdir()}
        assert "app-0" in names and {n.split("-")[0] for n in names} == {"python", "app"}

    # A daemon stopped cleanly and started again from its state directory comes back in a
    # new incarnation, in the script and the actor it ran.
    assert swarm.stop(3) == 0
    swarm.start(3)
    swarm.wait(
        "platform 3 back in incarnation 1, in B",
        lambda: swarm.status(3).get("incarnation") == 1 and swarm.status(3).get("actors") == ["B"],
    )
    assert swarm.status(3)["script"] == json.loads((tmp_path / "gs.json").read_text())["sha256"]
    assert swarm.events(3, "rejoined")[-1]["resumed"] is True
    swarm.wait("platform 3 back in the swarm", lambda: swarm.agreed_master((1, 2, 3)) is not None)

    # The operator's interventions, each answered per platform.
    other = next(p for p in (1, 2, 3) if p != swarm.agreed_master((1, 2, 3)))
    paused = swarm.gs("pause", "B", "--platforms", str(other))
    assert paused.returncode == 0, paused.stdout + paused.stderr
    assert paused.stdout.strip() == f"{other}: paused B"
    swarm.wait(
        "B paused",
        lambda: swarm.status(other).get("loaded", {}).get("B") == "sleeping",
        detail=lambda: str(swarm.status(other).get("loaded")),
    )
    assert swarm.status(other)["actors"] == []
    assert swarm.gs("activate", "B", "--platforms", str(other)).returncode == 0
    swarm.wait("B running again", lambda: swarm.status(other).get("actors") == ["B"])
    forced = swarm.gs("force", "B", "--to", "A", "--param", "why=test")
    assert forced.returncode == 0, forced.stdout + forced.stderr
    assert sorted(forced.stdout.split("\n")[:3]) == [f"  {p}: B -> A" for p in (1, 2, 3)]
    swarm.wait(
        "every platform forced into A",
        lambda: all(swarm.status(p).get("actors") == ["A"] for p in (1, 2, 3)),
    )
    refused = swarm.gs("pause", "B", "--platforms", str(other))
    assert refused.returncode == 1 and f"{other}: FAILED: " in refused.stdout

    # A backup, then kill -9: the restarted daemon resumes the actor it backed up.
    backed_up = swarm.gs("backup")
    assert backed_up.returncode == 0, backed_up.stdout + backed_up.stderr
    assert backed_up.stdout.count("backup generation") == 3
    swarm.kill(3)
    swarm.start(3)
    swarm.wait(
        "platform 3 resumed in A from its backup",
        lambda: swarm.status(3).get("incarnation") == 2 and swarm.status(3).get("actors") == ["A"],
    )
    assert swarm.events(3, "rejoined")[-1]["resumed"] is True
    stopped = swarm.gs("stop", "A", "--platforms", str(other))
    assert stopped.returncode == 0 and f"{other}: stopped A" in stopped.stdout
    swarm.wait(
        f"platform {other} without an actor",
        lambda: swarm.status(other).get("actors") == [],
        detail=lambda: str(swarm.status(other).get("loaded")),
    )


def test_start_is_refused_until_every_expected_platform_confirmed(
    swarm: LocalSwarm, tmp_path: Path
) -> None:
    swarm.start(1)
    swarm.wait("platform 1 up", lambda: swarm.status(1).get("master") == 1)
    script = SCRIPT
    state = ["--state", str(tmp_path / "gs.json")]
    deployed = swarm.gs("deploy", str(script), "--expect", "1-2", "--timeout", "2", *state)
    assert deployed.returncode == 1
    assert "confirmed by 1 of 2: [1]" in deployed.stdout
    assert "not confirmed by: [2]" in deployed.stderr
    refused = swarm.gs("start", "--timeout", "2", *state)
    assert refused.returncode == 1 and "2" in refused.stderr


def test_forged_wrongly_keyed_replayed_and_random_packets_are_rejected_and_counted(
    swarm: LocalSwarm, tmp_path: Path
) -> None:
    """A process on the network that is not the swarm: it records a genuine heartbeat and
    replays it, sends packets sealed with another swarm's key, an operator command without
    the ground station's signature, truncated and random bytes. Every daemon refuses and
    counts them, and keeps running."""
    from actorswarm.core.wire import GROUND_STATION, Heartbeat, encode
    from actorswarm.security import PacketGuard, init_keys, load_keys
    from actorswarm.transport import ZenohSettings, ZenohTransport

    for p in (1, 2):
        swarm.start(p)
    swarm.wait("two daemons joined", lambda: swarm.agreed_master((1, 2)) is not None)
    master = swarm.agreed_master((1, 2))
    captured: list[bytes] = []
    settings = ZenohSettings(connect=tuple(swarm.endpoints[:2]), multicast=False)
    with ZenohTransport(swarm.swarm, 9, settings) as intruder:

        def heard() -> bool:
            captured.extend(intruder.drain(100))
            return len(captured) > 5

        swarm.wait("a packet heard", heard)
        init_keys(tmp_path / "other")
        other = PacketGuard.from_keys(load_keys(tmp_path / "other"))
        heartbeat = encode(
            swarm=swarm.swarm, sender=9, incarnation=0, seq=1,
            body=Heartbeat(is_master=True, epoch=99, master=9),
        )  # fmt: skip
        mine = PacketGuard.from_keys(load_keys(swarm.keys))  # a captured robot's key
        operator = encode(
            swarm=swarm.swarm, sender=GROUND_STATION, incarnation=1, seq=1,
            body=Heartbeat(is_master=False, epoch=0, master=0),
        )  # fmt: skip
        sends = {
            "replay": [captured[0]] * 3,
            "bad_tag": [other.seal(heartbeat)],
            "unauthenticated": [heartbeat],
            "unsigned_operator": [mine.seal(operator)],
            "malformed": [captured[1][:9], b"\x00" * 40, os.urandom(200)],
        }
        for packets in sends.values():
            for data in packets:
                intruder.send(None, data)
        expected = {reason: len(packets) for reason, packets in sends.items()}
        # The recorded packet is one daemon's own: that daemon never checked it before, so
        # its first copy passes the guard (and the core drops it as its own); the other two
        # are replays there. The other daemon had heard the original: all three are replays.
        expected["replay"] = 2

        def counted() -> bool:
            return all(
                all(swarm.status(p).get("rejected", {}).get(r, 0) >= n for r, n in expected.items())
                for p in (1, 2)
            )

        swarm.wait(
            "every bad packet counted by both daemons",
            counted,
            detail=lambda: (
                f"expected {expected}, counted {[swarm.status(p).get('rejected') for p in (1, 2)]}"
            ),
        )
    for p in (1, 2):
        status = swarm.status(p)
        assert status["secure"] is True
        assert status["master"] == master, "the intruder's forged heartbeat claimed nothing"
        assert swarm.procs[p].poll() is None, "still running"
