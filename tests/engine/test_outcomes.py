"""What a reply says of a named command, and each platform's latest answer."""

from __future__ import annotations

from actorswarm.engine import commands as cmds
from actorswarm.ground.station import GroundStation, ReplyRecord


def test_a_reply_answers_only_the_command_it_names() -> None:
    paused = cmds.Result(command="Pause", ok=False, message="not loaded")
    assert cmds.outcome(paused, "Pause") == (False, "not loaded")
    assert cmds.outcome(paused, "Activate") is None
    backup = cmds.BackupReply(generation=3, size=120)
    assert cmds.outcome(backup, "Backup") == (True, "backup generation 3, 120 bytes")
    assert cmds.outcome(backup, "Pause") is None


def test_the_station_keeps_each_platform_s_latest_answer() -> None:
    station = GroundStation(swarm="t")
    station.replies += [
        ReplyRecord(1.0, 2, cmds.Result(command="Start", ok=False, message="no script")),
        ReplyRecord(1.5, 3, cmds.Result(command="Inject", ok=True, message="delivered")),
        ReplyRecord(2.0, 2, cmds.Result(command="Start", ok=True, message="started")),
    ]
    assert station.outcomes("Start") == {2: (True, "started")}
    assert station.outcomes("Inject") == {3: (True, "delivered")}


def test_a_command_nobody_acknowledges_is_retransmitted_until_its_deadline_then_named() -> None:
    """A platform that never acknowledges is retried until ``delivery_deadline`` (not
    dropped silently) and then listed as unreachable, so the operator is told which."""
    from actorswarm.core.config import CoreConfig

    station = GroundStation(swarm="t", config=CoreConfig(delivery_deadline=30.0))
    station.send(cmds.Pause(actor="A"), [4], 0.0)
    sent = len(station.ready().packets)
    now = 0.0
    while now < 29.0:
        now = station.next_deadline() or now + 1.0
        station.tick(now)
        sent += len(station.ready().packets)
    assert sent > 100, "retransmitted the whole time"
    assert station.unreachable == {}
    station.tick(31.0)
    assert set(station.unreachable) == {4}
