"""A real swarm recorded and shown again: three daemons flying simulated vehicles on
loopback, recorded by ``actorswarm gs record`` (stopped with Ctrl-C), drawn by
``actorswarm plot`` and played back by the web ground station (``web --replay``) in a real
browser, with pause, pace and seek."""

from __future__ import annotations

import hashlib
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from actorswarm.daemon.launch import LocalSwarm
from actorswarm.recording import read_recording
from actorswarm.sim.record import RecordError, Recording, read_record
from actorswarm.web import SimSource

BRANCH_MERGE = Path(__file__).resolve().parents[2] / "examples" / "branch_merge.xml"
FLY3 = """<TaskScript name="fly3" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Up</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.takeoff</_P_Name>
        <param key="altitude" value="12"/><param key="event" value="up_event"/></Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Hover</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="Up">
      <transition name="up_event" barrierKey="1" sysNum="all">
        <successor actor="Hover"/>
      </transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-3" actor="Up"/></_PlatformActorConfig>
</TaskScript>
"""


def _hovering(path: Path) -> bool:
    data = read_recording(path)  # every chunk but the open one is written: readable at any time
    return {tr["platform"] for tr in data.transitions if tr["to"] == "Hover"} == {1, 2, 3}


def _seen(path: Path) -> bool:
    try:
        return path.exists() and set(read_recording(path).platform.tolist()) == {1, 2, 3}
    except RecordError:
        return False  # created, its header not yet written: not readable yet


def _wait(what: str, ready: Any, recorder: subprocess.Popen[str]) -> None:
    end = time.monotonic() + 60
    while not ready():
        assert recorder.poll() is None, recorder.communicate()
        assert time.monotonic() < end, f"not {what} within 60 s"
        time.sleep(0.3)


@pytest.fixture(scope="module")
def real_recording(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, str]]:
    """``(recording, gs record's stderr)``: three daemons recorded from before the
    deployment until every vehicle hovers, then Ctrl-C."""
    tmp = tmp_path_factory.mktemp("real")
    script = tmp / "fly3.xml"
    script.write_text(FLY3)
    out = tmp / "flight.mcap"
    with LocalSwarm(tmp, 3, extra=("--vehicle", "sim")) as swarm:
        swarm.start_all()
        swarm.wait("three daemons with a master", lambda: swarm.agreed_master() is not None)
        cmd = [sys.executable, "-m", "actorswarm", "gs", "record", str(out), "--poll", "0.3",
               "--swarm", swarm.swarm, "--no-multicast", "--keys", str(swarm.keys)]  # fmt: skip
        for endpoint in swarm.endpoints:
            cmd += ["--connect", endpoint]
        recorder = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            _wait("recording every vehicle", lambda: _seen(out), recorder)
            state = ["--state", str(tmp / "gs.json")]
            deployed = swarm.gs("deploy", str(script), "--expect", "3", *state)
            assert deployed.returncode == 0, deployed.stdout + deployed.stderr
            started = swarm.gs("start", *state)
            assert started.returncode == 0, started.stdout + started.stderr
            _wait("every vehicle seen hovering", lambda: _hovering(out), recorder)
            time.sleep(1.0)  # a few hovering poses
            recorder.send_signal(signal.SIGINT)
            stdout, stderr = recorder.communicate(timeout=20)
        finally:
            if recorder.poll() is None:
                recorder.kill()
    assert recorder.returncode == 0, stderr
    assert f"wrote {out}" in stdout
    yield out, stderr


def test_a_real_flight_is_recorded_and_plotted(
    real_recording: tuple[Path, str], tmp_path: Path
) -> None:
    out, stderr = real_recording
    assert "recording" in stderr and "3 platforms up" in stderr, stderr
    data: Recording = read_recording(out)
    assert data.notes == [], "stopped with Ctrl-C: complete"
    assert data.meta["source"] == "gs record"
    assert set(data.platform.tolist()) == {1, 2, 3}
    for p in (1, 2, 3):
        times, xyz = data.path(p)
        assert len(times) >= 3
        assert xyz[0, 2] < 1.0, f"{p} started on the ground: {xyz[:, 2]}"
        assert 10.0 < xyz[-1, 2] < 13.5, f"{p} climbed to 12 m: {xyz[:, 2]}"
    # The recorder was displaced while gs deploy and gs start ran, and said so; it saw
    # the climb and the switch to Hover after.
    assert [e["what"] for e in data.events].count("gap") >= 1
    moves = {(tr["platform"], tr["from"], tr["to"]) for tr in data.transitions}
    assert {(p, "", "Up") for p in (1, 2, 3)} <= moves
    assert {(p, "Up", "Hover") for p in (1, 2, 3)} <= moves
    assert data.masters and len(data.masters[0]["masters"]) == 1
    # The operator's gs deploy and gs start, as the platforms answered them (gs start
    # deploys again, idempotently, to learn who has the script: confirmed twice).
    sha = hashlib.sha256(FLY3.encode()).hexdigest()[:12]
    answers = [(e["platform"], e["text"]) for e in data.events if e["what"] == "command"]
    for p in (1, 2, 3):
        assert answers.count((p, f"Deploy: confirmed {sha}")) == 2, answers
        assert answers.count((p, f"Start: started script {sha}")) == 1, answers
    assert {(e["what"], e["platform"]) for e in data.events} >= {("joined", p) for p in (1, 2, 3)}
    plotted = subprocess.run(
        [sys.executable, "-m", "actorswarm", "plot", str(out), "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert plotted.returncode == 0, plotted.stderr
    for name in ("flight-trajectories.png", "flight-timeline.png"):
        png = tmp_path / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


@pytest.mark.browser
def test_the_page_plays_the_real_recording_back_with_pause_pace_and_seek(
    real_recording: tuple[Path, str], page: Any
) -> None:
    from actorswarm.web import ReplaySource, Server

    out, _ = real_recording
    data = read_recording(out)
    up = min(tr["t"] for tr in data.transitions if tr["to"] == "Up")
    source = ReplaySource(data, speed=20.0, playing=False)
    with Server(source) as server:
        page.goto(server.url)
        page.wait_for_selector("#replay-box:not([hidden])")
        # A replay is not live: the badge says so.
        _wait_page(page, "document.querySelector('#link').textContent === 'replay'")
        assert page.get_attribute("#replay-play", "data-playing") == "0"
        assert page.text_content("#replay-play") == "Play"
        # Paused at 0, before the recorder heard anyone: nothing to show yet.
        _wait_page(page, "document.querySelector('#clock').textContent !== '—'")
        assert page.get_attribute("#map", "data-platforms") == "0"
        assert page.query_selector_all("#timeline li") == []
        # Seek past the take-off: the vehicles run Up on the map and in the table.
        page.eval_on_selector(
            "#replay-seek",
            f"(e) => {{ e.value = '{up + 0.1}'; e.dispatchEvent(new Event('change')); }}",
        )
        _wait_page(page, "document.querySelector('#legend').textContent.includes('Up3')")
        _wait_page(page, "document.querySelector('#map').dataset.platforms === '3'")
        _wait_page(
            page, "document.querySelectorAll('#swarm-table tr[data-state=joined]').length === 3"
        )
        # Play at ×20 to the end: the switch to Hover is a step of the timeline, and the
        # replay pauses itself there.
        page.click("#replay-play")
        page.wait_for_selector("#timeline li[data-from=Up][data-to=Hover]", timeout=30_000)
        # The operator's start, answered by all three, is on the timeline too.
        start = page.wait_for_selector("#timeline li.command[data-event^='Start: started']")
        assert start.get_attribute("data-count") == "3"
        assert "answered by 3 platforms: 1-3" in start.inner_text()
        _wait_page(page, "document.querySelector('#legend').textContent.includes('Hover3')")
        # The table as a live swarm's: Hover running, Up kept paused by the switch, one
        # switch out of Up and one into Hover, time running; the heartbeats, which a
        # recording does not hold, unknown rather than 0.
        _wait_page(
            page,
            "document.querySelector(\"#swarm-table tr[data-platform='1']\")"
            ".textContent.includes('+1 paused')",
        )
        row = page.query_selector("#swarm-table tr[data-platform='1']")
        cells = [c.inner_text() for c in row.query_selector_all("td")]
        assert [a.inner_text() for a in row.query_selector_all(".apill")] == ["Hover"], cells
        paused = row.query_selector("td span.muted")
        assert (paused.inner_text(), paused.get_attribute("title")) == ("+1 paused", "Up: paused")
        assert cells[3] == "2" and cells[4].endswith(" s") and cells[4] != "0.0 s", cells
        assert (cells[5], cells[7]) == ("—", "—"), "heard and incarnation are not recorded"
        # Paused at the end, the slider there (its step is 0.1 s).
        _wait_page(
            page,
            "document.querySelector('#replay-play').dataset.playing === '0' && "
            f"Number(document.querySelector('#replay-seek').value) > {source.end - 0.15}",
        )
        assert page.text_content("#replay-play") == "Play"
        assert source.now() == source.end and not source.playing
        # Back to the start: the page is told afresh, the timeline is empty again.
        page.eval_on_selector(
            "#replay-seek", "(e) => { e.value = '0'; e.dispatchEvent(new Event('change')); }"
        )
        _wait_page(page, "document.querySelectorAll('#timeline li').length === 0")
        assert page.text_content("#step-count") == "(0)"
        assert page.is_hidden("#tab-event"), "a replay takes no command"


def test_a_replay_puts_the_operators_commands_on_the_timeline(tmp_path: Path) -> None:
    from actorswarm.sim.record import RecordWriter
    from actorswarm.web import ReplaySource

    path = tmp_path / "ops.jsonl"
    with RecordWriter(path, {"name": "ops", "swarm": "s"}) as out:
        for p in (1, 2):
            out.event(0.0, "joined", p)
            out.transition({"t": 0.0, "platform": p, "from": "", "to": "A", "event": "",
                            "cause": "start"})  # fmt: skip
        out.event(2.0, "command", 1, "Inject: event go delivered")
        out.event(2.2, "command", 2, "Inject: event go delivered")
        for p in (1, 2):
            out.transition({"t": 2.5, "platform": p, "from": "A", "to": "B", "event": "go",
                            "cause": "barrier"})  # fmt: skip
        out.event(5.0, "command", 2, "Pause FAILED: no actor 'C'")
        out.pose(6.0, 1, 0.0, 0.0, 0.0)
    source = ReplaySource(read_record(path), playing=False)
    source.step(3.0)
    shown = [(s.cause, s.event, s.src, s.dst, s.platforms) for s in source.timeline.steps]
    assert shown == [
        ("command", "Inject: event go delivered", "", "", [1, 2]),
        ("barrier", "go", "A", "B", [1, 2]),
    ]
    source.step(3.0)
    last = source.timeline.steps[-1].to_json()
    assert (last["cause"], last["event"], last["platforms"]) == (
        "command", "Pause FAILED: no actor 'C'", [2],
    )  # fmt: skip
    # A command is no switch: the actors are the transitions' alone.
    assert source.frame()["counts"] == {"B": 2}
    source.seek(2.1)
    assert [(s.cause, s.platforms) for s in source.timeline.steps] == [("command", [1])]


def _wait_page(page: Any, script: str) -> None:
    page.wait_for_function(script, timeout=30_000)


def _small_recording(path: Path) -> Recording:
    """Two platforms flying east 1 m/s for 10 s; both switch A -> B at 4 s; platform 2
    is master until it leaves at 6 s, then platform 1."""
    from actorswarm.sim.record import RecordWriter

    with RecordWriter(path, {"name": "small", "swarm": "s"}) as out:
        for p in (1, 2):
            out.event(0.0, "joined", p)
            out.transition({"t": 0.0, "platform": p, "from": "", "to": "A", "event": "",
                            "cause": "start"})  # fmt: skip
        out.master(0.0, [2], 1)
        for i in range(11):
            out.pose(float(i), 1, float(i), 0.0, 5.0, 0.0)
            if i <= 6:
                out.pose(float(i), 2, float(i), 10.0, 5.0, 0.0)
        for p in (1, 2):
            out.transition({"t": 4.0, "platform": p, "from": "A", "to": "B", "event": "go",
                            "cause": "barrier"})  # fmt: skip
        out.event(6.0, "left", 2)
        out.master(6.5, [1], 2)
    return read_record(path)


def test_a_replay_shows_the_recording_at_its_time_and_seeks_both_ways(tmp_path: Path) -> None:
    import asyncio

    from actorswarm.web import ReplaySource
    from actorswarm.web import protocol as proto

    source = ReplaySource(_small_recording(tmp_path / "small.jsonl"), playing=False)
    assert source.end == 10.0 and source.hello()["replay"] == {"playing": False, "end": 10.0}
    source.step(2.5)
    frame = source.frame()
    assert frame["ids"] == [1, 2] and frame["x"] == [2.5, 2.5] and frame["y"] == [0.0, 10.0]
    assert frame["counts"] == {"A": 2}
    assert source.swarm_view()["master"] == 2
    source.step(5.0)  # to 7.5: both switched, 2 has left, 1 is master
    frame = source.frame()
    assert frame["counts"] == {"B": 1}
    view = source.swarm_view()
    assert view["master"] == 1 and view["epoch"] == 2
    assert {m["id"]: m["state"] for m in view["members"]} == {1: "joined", 2: "left"}
    assert [(s.src, s.dst, s.platforms) for s in source.timeline.steps][-1] == ("A", "B", [1, 2])
    # Backwards: the timeline is rebuilt up to the new time.
    assert source.seek(3.0) == "at 3.0 s of 10.0 s"
    assert source.timeline.steps == [], "the switch at 4 s is not yet"
    assert source.frame()["counts"] == {"A": 2}

    def ask(request: proto.Command) -> dict[str, Any]:
        # A thread of its own: a browser test before may leave this one's loop running.
        with ThreadPoolExecutor(1) as pool:
            return pool.submit(asyncio.run, source.execute(request)).result()

    refused = ask(proto.Event(name="go", id="e"))
    assert not refused["ok"] and "cannot be commanded" in refused["message"]
    bad = ask(proto.Seek(t=11.0, id="s"))
    assert not bad["ok"] and "from 0 to 10.0 s" in bad["message"]
    assert (ask(proto.Play(playing=True, id="p")))["ok"] and source.playing
    source.step(100.0)
    assert source.now() == 10.0 and not source.playing, "pauses at the end"
    assert (ask(proto.Speed(speed=5.0, id="v")))["ok"] and source.speed() == 5.0
    assert proto.decode('{"op": "seek", "t": 1.5}') == proto.Seek(t=1.5)


def test_web_replay_names_a_bad_recording(tmp_path: Path) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"type": "pose"}\n')
    for path, problem in ((bad, "line 1: the first line must be the meta line"),
                          (tmp_path / "none.jsonl", "No such file")):  # fmt: skip
        done = subprocess.run(
            [sys.executable, "-m", "actorswarm", "web", "--replay", str(path)],
            capture_output=True, text=True, timeout=60, check=False,
        )  # fmt: skip
        assert done.returncode == 2 and problem in done.stderr, done.stderr
        assert "Traceback" not in done.stderr


def test_gs_record_names_a_file_it_cannot_write(tmp_path: Path) -> None:
    out = tmp_path / "no" / "such" / "dir.jsonl"
    done = subprocess.run(
        [sys.executable, "-m", "actorswarm", "gs", "record", str(out), "--insecure",
         "--no-multicast", "--duration", "1"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert f"{out}: cannot write the recording" in done.stderr and "Traceback" not in done.stderr


def test_a_simulations_replay_shows_its_table_as_the_live_view_did(
    branch_merge: Callable[..., SimSource], tmp_path: Path
) -> None:
    """``sim --record`` then ``web --replay``: each platform's actors (the one running, the
    one a switch left paused), switches and time running are the live view's at the same
    time; when each was last heard and its incarnation, which a recording does not hold,
    are unknown rather than 0; the replay lasts as long as the simulation, not only to its
    last transition."""
    from actorswarm.recording import write_simulation
    from actorswarm.sim.tasksim import GroundEvent
    from actorswarm.web import ReplaySource

    live = branch_merge()
    live.sim.schedule([GroundEvent("AtoBC_branch_event", 5.0), GroundEvent("finish_event", 10.0)])
    seen: dict[float, dict[str, Any]] = {}
    for t in (7.0, 12.0):
        while live.now() < t - 1e-9:
            live.step(0.1)
        seen[t] = live.swarm_view()
    report = live.sim.report()
    path = tmp_path / "run.mcap"
    text = BRANCH_MERGE.read_text()
    meta = {"script": "branch-merge", "sim_time_s": 12.0, "source": "actorswarm sim"}
    write_simulation(path, report, meta=meta, script=(BRANCH_MERGE.name, text))
    replay = ReplaySource(read_recording(path), playing=False)
    assert replay.end == 12.0, "the simulated time, past the last transition at 10 s"

    def table(view: dict[str, Any]) -> dict[int, list[tuple[str, str, int, float]]]:
        return {
            m["id"]: [(a["name"], a["status"], a["switches"], a["running_s"]) for a in m["actors"]]
            for m in view["members"]
        }

    for t, view in seen.items():
        replay.seek(t)
        shown = replay.swarm_view()
        assert table(shown) == table(view), t
        assert table(shown)[1][-1][:2] == ("B", "sleeping" if t == 12.0 else "running")
        assert (shown["master"], shown["epoch"]) == (view["master"], view["epoch"])
        assert {(m["heard"], m["inc"]) for m in shown["members"]} == {(None, None)}
        assert {m["state"] for m in shown["members"]} == {"joined"}
        # Every platform of a simulation ran the script its recording carries.
        sha = hashlib.sha256(text.encode()).hexdigest()[:12]
        assert {m["script"] for m in shown["members"]} == {sha}
    # Sought back, the joins are still when they were.
    replay.seek(0.6)
    assert [(e["t"], e["what"]) for e in replay.swarm_view()["log"]] == [(0.0, "joined")] * 10
