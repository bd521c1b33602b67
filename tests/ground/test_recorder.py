"""The recording of a real swarm, written from a scripted ground station: status replies
and heartbeats in, an MCAP recording that ``read_recording`` reads back out (and the older
JSON Lines writer, still read)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from actorswarm.engine import commands as cmds
from actorswarm.ground.membership import Membership
from actorswarm.ground.recorder import SwarmRecorder
from actorswarm.ground.station import GroundStation
from actorswarm.recording import McapSink, Recorder, read_recording
from actorswarm.sim.record import RecordError, RecordWriter, actor_timeline, read_record


def _status(
    actors: dict[str, str], position: list[float] | None, vehicle: dict[str, object] | None = None
) -> cmds.StatusReply:
    return cmds.StatusReply(
        actors=actors,
        master=False,
        epoch=1,
        incarnation=7,
        position=position,
        vehicle=vehicle or {},  # type: ignore[arg-type]
    )


def _recorder(path: Path, meta: dict[str, object]) -> Recorder:
    return Recorder([McapSink(path)], meta=meta)


def _heartbeat(station: GroundStation, platform: int, now: float, master: bool, epoch: int) -> None:
    station.heard[platform] = now
    station.state[platform] = (7, master, epoch)


def test_status_replies_and_heartbeats_make_a_recording(tmp_path: Path) -> None:
    out = tmp_path / "real.mcap"
    station = GroundStation(swarm="s")
    membership = Membership(t_leave=1.0)
    t0 = 100.0
    writer = _recorder(out, {"name": "two"})
    rec = SwarmRecorder(writer, t0)
    for step in range(8):
        now = t0 + step * 0.5
        _heartbeat(station, 1, now, master=step < 4, epoch=1)
        if step < 5:  # platform 2 falls silent after 2 s
            _heartbeat(station, 2, now, master=False, epoch=1)
        if step >= 4:
            _heartbeat(station, 1, now, master=False, epoch=2)
            station.state[2] = (7, True, 2)
        actor = "Up" if step < 3 else "Hover"
        vehicle = {"battery": 1.0 - step * 0.01, "link": "up" if step < 6 else "lost"}
        rec.status(now, 1, _status({actor: "running"}, [step * 1.0, 0.0, 8.0], vehicle))
        rec.status(now, 2, _status({"Up": "running", "Spare": "sleeping"}, None))
        membership.update(station, now)
        rec.membership(now, membership)
    assert writer.counts["pose"] == 8
    writer.close()
    back = read_recording(out)
    assert back.meta == {"name": "two"}
    # Poses only where a position came, at times since t0, heading along the move.
    assert back.platform.tolist() == [1] * 8
    assert back.t.tolist() == [0.5 * i for i in range(8)]
    assert back.x.tolist() == [float(i) for i in range(8)]
    assert back.heading.tolist()[1:] == [0.0] * 7
    # What ran already is a start at the first reply; the switch is dated by its reply.
    moves = [(tr["t"], tr["platform"], tr["from"], tr["to"]) for tr in back.transitions]
    assert moves == [(0.0, 1, "", "Up"), (0.0, 2, "", "Up"), (1.5, 1, "Up", "Hover")]
    assert all(tr["cause"] == "observed" for tr in back.transitions)
    spans = actor_timeline(back.transitions)
    assert (1, "Up", 0.0, 1.5) in spans and (1, "Hover", 1.5, None) in spans
    # Joins, then platform 2 leaving once unheard for t_leave; the master hand-over.
    events = [(e["t"], e["what"], e["platform"]) for e in back.events]
    assert events == [
        (0.0, "vehicle", 1),  # link up
        (0.0, "joined", 1),
        (0.0, "joined", 2),
        (3.0, "fault", 1),  # link lost
        (3.5, "left", 2),
    ]
    assert back.events[3]["text"] == "link lost"
    masters = [(m["t"], m["masters"], m["epoch"]) for m in back.masters]
    assert masters[0] == (0.0, [1], 1)
    assert (2.0, [2], 2) in masters
    assert masters[-1] == (3.5, [], 2), "the master left: none claims it"
    assert back.end_time() == 3.5


def test_a_json_lines_recording_cut_short_is_readable_up_to_its_last_line(
    tmp_path: Path,
) -> None:
    out = tmp_path / "cut.jsonl"
    writer = RecordWriter(out, {"name": "cut"})
    writer.pose(0.0, 1, 1.0, 2.0, 3.0)
    writer.master(0.0, [1], 4)
    # Not closed: every line is already on disk.
    back = read_record(out)
    assert len(back) == 1 and back.masters == [{"t": 0.0, "masters": [1], "epoch": 4}]
    writer.close()
    assert writer.closed


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ({"type": "master", "t": 1.0, "masters": ["1"], "epoch": 1}, "list of platform IDs"),
        ({"type": "master", "t": 1.0, "masters": [1], "epoch": 1.5}, "'epoch' must be"),
        ({"type": "event", "t": 1.0, "what": "joined", "platform": 1}, "'text' must be"),
        ({"type": "event", "t": "x", "what": "joined", "platform": 1, "text": ""}, "'t' must"),
        ({"type": "command", "t": 1.0}, "unknown type 'command'"),
    ],
)
def test_bad_master_and_event_lines_are_named(
    tmp_path: Path, line: dict[str, object], problem: str
) -> None:
    out = tmp_path / "bad.jsonl"
    meta = {"type": "meta", "format": "actorswarm-record", "version": 1}
    out.write_text(json.dumps(meta) + "\n" + json.dumps(line) + "\n")
    with pytest.raises(RecordError, match=problem) as info:
        read_record(out)
    assert "line 2" in str(info.value)


def test_the_writer_refuses_what_the_format_cannot_hold(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="reserved"):
        RecordWriter(tmp_path / "x.jsonl", {"version": 2})
    with RecordWriter(tmp_path / "y.jsonl", {}) as writer:
        with pytest.raises(ValueError, match=r"not finite|cannot record"):
            writer.pose(0.0, 1, float("nan"), 0.0, 0.0)
        with pytest.raises(ValueError, match=r"'type'"):
            writer.transition({"type": "x", "t": 0.0})
    assert read_record(tmp_path / "y.jsonl").transitions == []


def test_answers_to_the_operators_commands_are_recorded_as_the_platforms_worded_them(
    tmp_path: Path,
) -> None:
    out = tmp_path / "commands.mcap"
    sha = "ab" * 32
    writer = _recorder(out, {"name": "ops"})
    rec = SwarmRecorder(writer, 10.0)
    rec.reply(11.0, 1, cmds.DeployAck(sha256=sha))
    rec.reply(11.5, 2, cmds.Result(command="DeployChunk", ok=False, message="script refused"))
    started = f"started script {sha[:12]}"
    rec.reply(12.0, 1, cmds.Result(command="Start", ok=True, message=started))
    rec.reply(12.25, 2, cmds.Result(command="Force", ok=False, message="no actor 'Z'"))
    rec.reply(13.0, 1, cmds.BackupReply(generation=4, size=120))
    # A status reply is the recorder's own business: a transition, not a command.
    rec.reply(13.5, 1, _status({"Up": "running"}, None))
    assert rec.commands == 5
    writer.close()
    back = read_recording(out)
    said = [(e["t"], e["what"], e["platform"], e["text"]) for e in back.events]
    assert said == [
        (1.0, "command", 1, f"Deploy: confirmed {sha[:12]}"),
        (1.5, "command", 2, "Deploy FAILED: script refused"),
        (2.0, "command", 1, f"Start: started script {sha[:12]}"),
        (2.25, "command", 2, "Force FAILED: no actor 'Z'"),
        (3.0, "command", 1, "Backup: generation 4, 120 bytes"),
    ]
    assert [(tr["t"], tr["to"]) for tr in back.transitions] == [(3.5, "Up")]
