"""The live Foxglove view: a WebSocket client speaking Foxglove's protocol (as Foxglove
does) connects to a recorder's live server on loopback, is told the channels, subscribes
to some and receives the recorder's messages as they are written; ``sim --live`` serves
and records the same run."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("foxglove")
from websockets.sync.client import ClientConnection, connect

from actorswarm.recording import TOPICS, Recorder, read_recording
from actorswarm.recording.live import LiveSink

SCRIPT = Path(__file__).parents[2] / "examples" / "takeoff_ingress_return.xml"


def _json(ws: ClientConnection, op: str) -> dict[str, Any]:
    """The next text message of ``op`` (skipping others), within 5 s."""
    end = time.monotonic() + 5
    while time.monotonic() < end:
        message = ws.recv(timeout=5)
        if isinstance(message, str) and json.loads(message)["op"] == op:
            return dict(json.loads(message))
    raise AssertionError(f"no {op} within 5 s")


def test_a_foxglove_client_gets_the_channels_and_the_messages() -> None:
    live = LiveSink(port=0)
    assert live.host == "127.0.0.1", "loopback unless asked"
    recorder = Recorder([live], meta={"name": "live"})
    try:
        with connect(live.url, subprotocols=["foxglove.sdk.v1"], open_timeout=5) as ws:
            assert ws.subprotocol == "foxglove.sdk.v1"
            assert _json(ws, "serverInfo")["name"] == "actorswarm"
            channels = {c["topic"]: c for c in _json(ws, "advertise")["channels"]}
            assert set(channels) == set(TOPICS)
            for topic, channel in channels.items():
                assert channel["schemaName"] == TOPICS[topic] and channel["encoding"] == "json"
            wanted = {1: channels["/log"]["id"], 2: channels["/tf"]["id"]}
            subscribe = [{"id": sub, "channelId": ch} for sub, ch in wanted.items()]
            ws.send(json.dumps({"op": "subscribe", "subscriptions": subscribe}))
            got: dict[int, list[tuple[int, dict[str, Any]]]] = {1: [], 2: []}
            end = time.monotonic() + 10
            step = 0
            while not (got[1] and got[2]):
                assert time.monotonic() < end, "no message within 10 s of subscribing"
                # The subscription takes effect a moment after it is sent: keep writing.
                recorder.pose(step * 0.5, 7, float(step), 2.0, 3.0)
                recorder.snapshot(step * 0.5)
                recorder.event(step * 0.5, "joined", 7)
                step += 1
                try:
                    frame = ws.recv(timeout=0.2)
                except TimeoutError:
                    continue
                while True:
                    if isinstance(frame, bytes):
                        opcode, sub, log_time = struct.unpack_from("<BIQ", frame)
                        assert opcode == 1
                        got[sub].append((log_time, json.loads(frame[13:])))
                    try:
                        frame = ws.recv(timeout=0.05)
                    except TimeoutError:
                        break
    finally:
        recorder.close()
    log_time, line = got[1][0]
    assert line["message"] == "joined" and line["name"] == "platform/7"
    assert line["timestamp"]["sec"] * 10**9 + line["timestamp"]["nsec"] == log_time
    _, transforms = got[2][0]
    assert transforms["transforms"][0]["child_frame_id"] == "platform/7"


def test_sim_live_serves_and_records_the_same_run(tmp_path: Path) -> None:
    out = tmp_path / "live.mcap"
    done = subprocess.run(
        [sys.executable, "-m", "actorswarm", "sim", str(SCRIPT), "--live", "--live-port", "0",
         "--record", str(out), "--duration", "8", "--speed", "50"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "live Foxglove view on ws://127.0.0.1:" in done.stdout
    data = read_recording(out)
    assert data.notes == []
    assert set(data.platform.tolist()) == set(range(1, 11))
    assert data.masters and data.masters[0]["masters"] == [1]
    assert {tr["to"] for tr in data.transitions} >= {"Standby"}


def test_a_live_view_that_cannot_start_says_why(monkeypatch: pytest.MonkeyPatch) -> None:
    from actorswarm.recording.live import LiveUnavailable

    first = LiveSink(port=0)
    try:
        with pytest.raises(LiveUnavailable, match=f"127.0.0.1:{first.port}.*--live-port"):
            LiveSink(port=first.port)
    finally:
        first.close()
    monkeypatch.setitem(sys.modules, "foxglove", None)  # as if the extra were not installed
    with pytest.raises(LiveUnavailable, match=r"pip install 'actorswarm\[foxglove\]'"):
        LiveSink(port=0)


def test_the_command_line_and_the_live_view_agree_on_the_port() -> None:
    from actorswarm.cli.record_cmd import LIVE_PORT
    from actorswarm.cli.web_cmd import DEFAULT_PORT
    from actorswarm.recording.live import DEFAULT_LIVE_PORT

    assert LIVE_PORT == DEFAULT_LIVE_PORT != DEFAULT_PORT, "not the web ground station's port"


def test_gs_record_live_serves_while_it_records(tmp_path: Path) -> None:
    out = tmp_path / "real.mcap"
    done = subprocess.run(
        [sys.executable, "-m", "actorswarm", "gs", "record", str(out), "--insecure",
         "--no-multicast", "--duration", "1", "--live", "--live-port", "0"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "live Foxglove view on ws://127.0.0.1:" in done.stdout
    data = read_recording(out)  # no swarm to hear: complete, with nothing in it
    assert data.meta["source"] == "gs record" and len(data) == 0
    assert not any("cut short" in note for note in data.notes), data.notes
