"""Recordings that go wrong: a ``gs record`` killed outright (SIGKILL), a file cut short,
a foreign MCAP file, one from a newer version, a channel missing, a path that cannot be
written; and an older JSON Lines recording converted."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.records import Message
from mcap.stream_reader import StreamReader
from mcap.writer import Writer
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.recording import McapSink, Recorder, RecordingWriteError, read_recording
from actorswarm.recording.mcap_sink import check_writable
from actorswarm.sim.record import RecordError, RecordWriter

runner = CliRunner()


def _move(t: float, p: int, src: str, dst: str, event: str) -> dict[str, object]:
    cause = "barrier" if event else "start"
    return {"t": t, "platform": p, "from": src, "to": dst, "event": event, "cause": cause}


def _small(path: Path, *, platforms: int = 3, seconds: int = 20) -> Recorder:
    """A recorder on ``path`` fed ``seconds`` of ``platforms`` flying east, an actor
    switch at 5 s and a master, not closed."""
    rec = Recorder([McapSink(path)], meta={"name": "small"})
    rec.master(0.0, [1], 1)
    for p in range(1, platforms + 1):
        rec.transition(_move(0.0, p, "", "A", ""))
    for i in range(seconds * 2):
        t = i * 0.5
        if t == 5.0:
            for p in range(1, platforms + 1):
                rec.transition(_move(t, p, "A", "B", "go"))
        for p in range(1, platforms + 1):
            rec.pose(t, p, t, 10.0 * p, 5.0)
        rec.snapshot(t)
    return rec


def test_a_killed_gs_record_leaves_a_readable_file(tmp_path: Path) -> None:
    """A real ``gs record`` process (no swarm to hear: it records that none is up) killed
    with SIGKILL: the file reads back up to about a second before the kill."""
    out = tmp_path / "killed.mcap"
    cmd = [sys.executable, "-m", "actorswarm", "gs", "record", str(out), "--insecure",
           "--no-multicast", "--poll", "0.5"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    started = time.time_ns()
    try:
        deadline = time.monotonic() + 30
        while not (out.exists() and out.stat().st_size > 2000):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "gs record wrote nothing within 30 s"
            time.sleep(0.1)
        time.sleep(2.5)
        killed = time.time_ns()
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    data = read_recording(out)
    assert data.meta["source"] == "gs record"
    assert any("cut short" in note for note in data.notes), data.notes
    # The last message written: the swarm's metrics (platforms up), every look (0.5 s).
    times: list[int] = []
    with out.open("rb") as stream, contextlib.suppress(Exception):  # no footer: it ends badly
        for record in StreamReader(stream).records:
            if isinstance(record, Message):
                times.append(record.log_time)
    assert times and times[0] >= started - 10**9
    lost = (killed - max(times)) / 1e9
    # At most a second is lost (the open chunk is flushed every second, a message comes
    # every half second); the margin is for a busy machine's late loop.
    assert lost < 2.0, f"{lost:.2f} s lost"


def test_a_file_cut_short_reads_up_to_the_cut(tmp_path: Path) -> None:
    whole = tmp_path / "whole.mcap"
    _small(whole).close()
    full = read_recording(whole)
    assert full.notes == [] and len(full.transitions) == 6 and len(full) == 120
    data = whole.read_bytes()
    cut = tmp_path / "cut.mcap"
    # Flushed in small chunks, as gs record does, then cut in the middle of the last one.
    rec = Recorder([McapSink(cut, flush_every=0.0, clock=time.monotonic)], meta={"n": 1})
    for i in range(20):
        rec.pose(i * 0.5, 1, float(i), 0.0, 0.0)
        rec.snapshot(i * 0.5)
    rec.close()
    raw = cut.read_bytes()
    cut.write_bytes(raw[: len(raw) // 3])
    part = read_recording(cut)
    assert any("cut short" in note for note in part.notes), part.notes
    assert 3 <= len(part) < 20
    assert part.t.tolist() == [i * 0.5 for i in range(len(part))]
    assert data[:8] == b"\x89MCAP0\r\n"
    # The command line shows it, and says what was lost.
    shown = runner.invoke(app, ["plot", str(cut), "--out", str(tmp_path)])
    assert shown.exit_code == 0, shown.output
    assert "cut short" in shown.output


def test_a_foreign_mcap_file_is_named_and_refused(tmp_path: Path) -> None:
    foreign = tmp_path / "foreign.mcap"
    with foreign.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema("pose", "jsonschema", b"{}")
        channel = writer.register_channel("/pose", "json", schema)
        writer.add_message(channel, log_time=1, data=b"{}", publish_time=1)
        writer.finish()
    with pytest.raises(RecordError, match=r"foreign\.mcap: an MCAP file, but not an actorswarm"):
        read_recording(foreign)
    done = subprocess.run(
        [sys.executable, "-m", "actorswarm", "web", "--replay", str(foreign)],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 2 and "not an actorswarm recording" in done.stderr
    assert str(foreign) in done.stderr and "Traceback" not in done.stderr


def test_a_newer_version_says_to_upgrade(tmp_path: Path) -> None:
    newer = tmp_path / "newer.mcap"
    with newer.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        writer.add_metadata("actorswarm", {"format": "actorswarm", "version": "99", "t0_ns": "0"})
        writer.finish()
    with pytest.raises(RecordError, match=r"newer\.mcap: written by a newer actorswarm.*upgrade"):
        read_recording(newer)


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (b"", "line 1: empty recording"),
        (b"\x89MC", "ends within its magic bytes"),
        (b"\x00\x01binary", "line 1: not JSON"),
        (b"\xff\xfe\x00", "neither an MCAP recording nor a JSON Lines one"),
        (b"\x89MCAP0\r\n\x01\x02", "not a readable MCAP file"),
    ],
)
def test_garbage_is_named(tmp_path: Path, content: bytes, problem: str) -> None:
    bad = tmp_path / "bad.rec"
    bad.write_bytes(content)
    with pytest.raises(RecordError, match=problem) as info:
        read_recording(bad)
    assert str(bad) in str(info.value)


def test_a_missing_channel_is_said_and_the_rest_shown(tmp_path: Path) -> None:
    path = tmp_path / "no-poses.mcap"
    rec = Recorder([McapSink(path)], meta={})
    rec.transition(_move(1.0, 1, "", "A", ""))
    rec.close()
    data = read_recording(path)
    assert len(data.transitions) == 1 and len(data) == 0
    assert data.notes == [
        "no /platforms messages: no positions",
        "no /actorswarm/masters messages: no master changes",
    ]


def test_a_path_that_cannot_be_written_is_named(tmp_path: Path) -> None:
    bad = Path("/proc/nope/x.mcap")
    with pytest.raises(RecordingWriteError, match=r"/proc/nope/x\.mcap: cannot write the rec"):
        McapSink(bad)
    with pytest.raises(RecordingWriteError, match="writable directory"):
        check_writable(bad)
    script = Path(__file__).parents[2] / "examples" / "takeoff_ingress_return.xml"
    result = runner.invoke(app, ["sim", str(script), "--record", str(bad), "--duration", "60"])
    assert result.exit_code == 2
    # refused by the command's check of its output paths, one line naming the path
    assert "/proc/nope/x.mcap" in result.output and "cannot" in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert "invariants" not in result.output, "refused before the run, not after"
    check_writable(tmp_path / "ok.mcap")
    assert list(tmp_path.iterdir()) == [], "the check leaves nothing behind"


def test_an_older_json_lines_recording_converts(tmp_path: Path) -> None:
    old = tmp_path / "old.jsonl"
    with RecordWriter(old, {"name": "old", "areas": {"a": [[0, 0], [10, 0], [10, 10]]}}) as out:
        out.event(0.0, "joined", 1)
        out.transition(_move(0.0, 1, "", "A", ""))
        out.master(0.0, [1], 3)
        for i in range(5):
            out.pose(float(i), 1, float(i), 2.0, 3.0, 0.5, "flying")
        out.event(2.0, "command", 1, "Inject: event go delivered")
    new = tmp_path / "new.mcap"
    result = runner.invoke(app, ["record", "convert", str(old), str(new)])
    assert result.exit_code == 0, result.output
    a, b = read_recording(old), read_recording(new)
    assert b.rows() == a.rows()
    assert b.transitions == a.transitions and b.masters == a.masters and b.events == a.events
    assert b.areas() == {"a": [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]}
    assert json.loads(json.dumps(b.meta))["name"] == "old"
    refused = runner.invoke(app, ["record", "convert", str(tmp_path / "none.jsonl"), str(new)])
    assert refused.exit_code == 2 and "none.jsonl" in refused.output
