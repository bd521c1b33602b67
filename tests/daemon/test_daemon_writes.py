"""Nothing written when nothing changed: the daemon's status file and replay windows are
written when what they say changed, at most once a second (the replay windows every 5 s),
the packet counters alone at most every 10 s; a clean stop backs up only a state the last
backup does not hold. The daemon's own writer (:class:`~actorswarm.daemon.run.DaemonFiles`)
driven by a fake clock, on a real platform endpoint."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from actorswarm.daemon import run
from actorswarm.daemon.endpoint import PlatformEndpoint
from actorswarm.daemon.loop import Traffic
from actorswarm.daemon.run import DaemonFiles
from actorswarm.daemon.state import StateDir, WritePacer
from actorswarm.runtime.storage import MemoryBackupStore

WAKE = 0.01  # the loop wakes 100 times a second (a busy swarm)


class FakeGuard:
    """What the writer reads of a packet guard."""

    secure = True

    def __init__(self) -> None:
        self.accepted = 0
        self.rejected: Counter[str] = Counter()
        self.windows: dict[int, tuple[int, int]] = {2: (1, 10)}

    def replay_snapshot(self) -> dict[int, tuple[int, int]]:
        return dict(self.windows)


class Writes:
    """Every write of ``status.json`` and ``replay.json``, with the fake time it happened."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, state: StateDir) -> None:
        self.status: list[float] = []
        self.replay: list[dict[int, tuple[int, int]]] = []
        self.now = 0.0
        real = run._write_status

        def write_status(path: Path, content: object, meters: object, now: float) -> None:
            self.status.append(now)
            real(path, content, meters, now)  # type: ignore[arg-type]

        monkeypatch.setattr(run, "_write_status", write_status)
        monkeypatch.setattr(state, "save_replay_windows", self.replay.append)


@pytest.fixture
def daemon(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[DaemonFiles, Writes]:
    state = StateDir(tmp_path / "state")
    endpoint = PlatformEndpoint(
        1, swarm="writes", incarnation=1, now=0.0, store=MemoryBackupStore()
    )
    writes = Writes(monkeypatch, state)
    files = DaemonFiles(state, endpoint, FakeGuard(), Traffic())  # type: ignore[arg-type]
    return files, writes


def _run(files: DaemonFiles, start: float, seconds: float, each: object = None) -> None:
    """Wake the writer every WAKE seconds from ``start`` for ``seconds`` (calling ``each``
    with the time before each wake)."""
    steps = round(seconds / WAKE)
    for i in range(steps):
        t = start + i * WAKE
        if callable(each):
            each(t)
        files.wake(t)


def test_nothing_is_written_when_nothing_changed(daemon: tuple[DaemonFiles, Writes]) -> None:
    files, writes = daemon
    _run(files, 0.0, 60.0)
    # The status once, when the daemon starts; the replay windows restored from the disk
    # never, since no packet was accepted.
    assert writes.status == [0.0]
    assert writes.replay == []
    status = json.loads(files.status_file.read_text())
    assert status["platform"] == 1 and status["t"] == 0.0
    # A clean stop with nothing new writes nothing either.
    files.close(60.0)
    assert writes.status == [0.0] and writes.replay == []


def test_a_state_changing_all_the_time_is_written_at_most_once_a_second(
    daemon: tuple[DaemonFiles, Writes],
) -> None:
    files, writes = daemon
    guard = files.guard

    def reject(t: float) -> None:
        guard.rejected["bad_tag"] += 1  # a new count at every wake: the state changed

    _run(files, 0.0, 30.0, reject)
    gaps = [b - a for a, b in zip(writes.status, writes.status[1:], strict=False)]
    assert 29 <= len(writes.status) <= 31
    assert min(gaps) >= 1.0 - 1e-9
    # Written within a second of the change: what is on disk is at most a second old.
    assert json.loads(files.status_file.read_text())["rejected"]["bad_tag"] >= 2900
    # The stop writes the last state.
    files.close(30.0)
    assert json.loads(files.status_file.read_text())["rejected"]["bad_tag"] == 3000


def test_a_change_is_written_within_a_second_then_nothing(
    daemon: tuple[DaemonFiles, Writes],
) -> None:
    """The platform itself changes: alone, it claims the master role after its boot wait."""
    files, writes = daemon
    endpoint = files.endpoint
    _run(files, 0.0, 20.0, endpoint.tick)
    assert endpoint.node.is_master
    claimed = json.loads(files.status_file.read_text())
    assert claimed["master"] == 1 and claimed["is_master"] is True
    # Written once at start, then when the role changed (within a second of it); no more.
    assert len(writes.status) <= 4
    last = writes.status[-1]
    _run(files, 20.0, 20.0, endpoint.tick)
    assert writes.status[-1] == last


def test_packet_counters_alone_are_written_at_most_every_ten_seconds(
    daemon: tuple[DaemonFiles, Writes],
) -> None:
    files, writes = daemon
    traffic = files.traffic

    def count(t: float) -> None:
        traffic.sent_packets += 1
        traffic.sent_bytes += 120

    _run(files, 0.0, 60.0, count)
    gaps = [b - a for a, b in zip(writes.status, writes.status[1:], strict=False)]
    assert 6 <= len(writes.status) <= 7 and min(gaps) >= 10.0 - 1e-9
    on_disk = json.loads(files.status_file.read_text())["traffic"]["sent_packets"]
    assert on_disk >= traffic.sent_packets - 10 / WAKE
    files.close(60.0)  # the stop writes the last counters
    assert json.loads(files.status_file.read_text())["traffic"]["sent_packets"] == 6000


def test_replay_windows_are_written_when_a_packet_moved_them(
    daemon: tuple[DaemonFiles, Writes],
) -> None:
    files, writes = daemon
    guard = files.guard

    def accept(t: float) -> None:
        if t < 20.0:  # packets for 20 s, then silence
            inc, top = guard.windows[2]
            guard.windows[2] = (inc, top + 1)

    _run(files, 0.0, 60.0, accept)
    assert 4 <= len(writes.replay) <= 5  # every 5 s while packets came, never after
    assert writes.replay[-1] == guard.replay_snapshot()
    files.close(60.0)
    assert len(writes.replay) <= 5


def test_the_pacer_alone() -> None:
    pacer = WritePacer(1.0, 10.0, seen="on disk")
    assert not pacer.changed(0.0, "on disk")  # what the disk holds already
    assert pacer.changed(1.0, "new")
    assert not pacer.due(1.5) and not pacer.changed(1.5, "newer")  # a second not over
    assert pacer.changed(2.0, "newer")
    # Counters alone wait 10 s after the last write.
    assert not pacer.changed(3.0, "newer", meters=1)
    assert not pacer.changed(11.5, "newer", meters=2)
    assert pacer.changed(12.5, "newer", meters=3)
    assert pacer.writes == 3
    assert not pacer.changed(12.6, "newer", meters=3, closing=True)  # nothing new
    assert pacer.changed(12.7, "newer", meters=4, closing=True)  # the stop writes the rest


def test_a_clean_stop_backs_up_only_what_the_last_backup_does_not_hold(tmp_path: Path) -> None:
    from actorswarm.runtime.storage import FileBackupStore

    endpoint = PlatformEndpoint(
        1, swarm="writes", incarnation=1, now=0.0, store=FileBackupStore(tmp_path)
    )
    assert endpoint.backup(changed_only=True) is None  # no script: nothing to resume
    endpoint.engine.script_sha = "0" * 64  # as if a script ran (no actor loaded)
    assert endpoint.backup() == 1
    assert endpoint.backup(changed_only=True) is None  # the same state: not written again
    assert sorted(p.name for p in tmp_path.iterdir()) == ["backup-000001.bin"]
    assert endpoint.backup() == 2  # asked for (a transition, the operator): written


def test_a_log_line_that_cannot_be_written_does_not_stop_the_daemon(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import io
    import json
    import sys

    from actorswarm.daemon import run

    run._log("master", master=3)
    (line,) = capsys.readouterr().err.splitlines()
    assert json.loads(line)["event"] == "master" and json.loads(line)["master"] == 3

    class Gone(io.StringIO):
        def write(self, text: str) -> int:
            raise BrokenPipeError("the reader of stderr went away")

    monkeypatch.setattr(sys, "stderr", Gone())
    run._log("master", master=4)  # lost, and no exception
    closed = io.StringIO()
    closed.close()
    monkeypatch.setattr(sys, "stderr", closed)
    run._log("master", master=5)  # ValueError on a closed file: lost too
