"""What the launcher shows of a daemon: /proc figures of a real process, status.json, and
the table's rows."""

from __future__ import annotations

import json
import os
from pathlib import Path

from rich.console import Console

from actorswarm.launch.config import LaunchFile, PlatformPlan
from actorswarm.launch.monitor import ProcSample, Row, read_status, sample
from actorswarm.launch.runner import Launcher


def test_this_process_has_cpu_time_and_resident_memory() -> None:
    figures = sample(os.getpid(), 1.0)
    assert figures is not None
    assert figures.cpu_s > 0 and figures.rss > 1 << 20
    assert sample(2**22 + 1, 1.0) is None  # no such process


def test_cpu_share_is_cpu_time_over_wall_time_between_two_samples(tmp_path: Path) -> None:
    row = Row(3)
    status = {"master": 1, "actors": ["A", "B"], "incarnation": 2}
    row.update(status, ProcSample(10.0, 4.0, 50 << 20))
    assert row.cpu_percent is None and row.rss == 50 << 20  # one sample: no share yet
    row.update(status, ProcSample(12.0, 4.5, 51 << 20))
    assert row.cpu_percent == 25.0
    assert (row.master, row.actors, row.incarnation) == (1, ("A", "B"), 2)
    (tmp_path / "status.json").write_text(json.dumps(status))
    assert read_status(tmp_path) == status
    (tmp_path / "status.json").write_text("{not json")
    assert read_status(tmp_path) == {}


def test_the_table_shows_each_daemon_and_the_summary_their_master(tmp_path: Path) -> None:
    plans = tuple(PlatformPlan(p, "none", None, None, tmp_path / f"s{p}") for p in (1, 2))
    plan = LaunchFile(
        source=tmp_path / "f.toml", swarm="t", directory=tmp_path, keys=None, insecure=True,
        multicast=True, host="127.0.0.1", ports=(), plans=plans,
    )  # fmt: skip
    console = Console(width=120, record=True)
    launcher = Launcher(plan, None, console)
    one, two = launcher.rows[1], launcher.rows[2]
    one.pid, one.up, one.master, one.actors, one.rss = 41, True, 1, ("A",), 60 << 20
    two.pid, two.exit_code, two.restarts = 42, 1, 1
    assert launcher.summary() == "1 of 2 up, master 1"
    console.print(launcher.table())
    text = console.export_text()
    assert "swarm t: r ID + Enter restarts one, Ctrl-C stops all" in text
    assert "60 MiB" in text and "exit 1 (restarted 1)" in text
    launcher.handle("r 7")
    launcher.handle("hello")
    said = console.export_text()
    assert "no platform 7 in this launch: [1, 2]" in said and "`r ID` to restart" in said


def test_a_restart_request_reaches_a_running_launcher_through_its_control_file(
    tmp_path: Path,
) -> None:
    from actorswarm.launch.runner import CONTROL, PIDFILE, request

    assert (
        request(tmp_path, "r 3")
        == f"no launcher is running on {tmp_path} (no live {PIDFILE} there)"
    )
    (tmp_path / PIDFILE).write_text(f"{os.getpid()}\n")  # a live process: this one
    assert request(tmp_path, "r 3") is None
    assert (tmp_path / CONTROL).read_text() == "r 3\n"
