"""A real swarm recorded and shown again: three daemons flying simulated vehicles on
loopback, recorded by ``actorswarm gs record`` (stopped with Ctrl-C), drawn by
``actorswarm plot`` and played back by the web ground station (``web --replay``) in a real
browser, with pause, pace and seek."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from actorswarm.daemon.launch import LocalSwarm
from actorswarm.sim.record import Recording, read_record

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
    data = read_record(path)  # every line is whole: readable at any time
    return {tr["platform"] for tr in data.transitions if tr["to"] == "Hover"} == {1, 2, 3}


def _seen(path: Path) -> bool:
    return path.exists() and set(read_record(path).platform.tolist()) == {1, 2, 3}


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
    out = tmp / "flight.jsonl"
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
    data: Recording = read_record(out)
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
    assert {(e["what"], e["platform"]) for e in data.events} >= {("joined", p) for p in (1, 2, 3)}
    plotted = subprocess.run(
        [sys.executable, "-m", "actorswarm", "plot", str(out), "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert plotted.returncode == 0, plotted.stderr
    for name in ("flight-trajectories.png", "flight-timeline.png"):
        png = tmp_path / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
