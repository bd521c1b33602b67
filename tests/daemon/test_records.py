"""A daemon keeps none of what its engine records: every switch, ignored event and plugin
failure goes to its log once, ``status.json`` shows the last 50 switches, and the
engine's lists are emptied on every wake, so a daemon that switches for months does not
grow (:class:`~actorswarm.daemon.records.EngineRecords`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from actorswarm.daemon.endpoint import PlatformEndpoint
from actorswarm.daemon.loop import Traffic
from actorswarm.daemon.records import STATUS_TRANSITIONS, EngineRecords
from actorswarm.daemon.run import DaemonFiles
from actorswarm.daemon.state import StateDir
from actorswarm.engine.records import TransitionRecord
from actorswarm.runtime.actor_runtime import PluginFailure
from actorswarm.runtime.storage import MemoryBackupStore
from actorswarm.security.guard import PacketGuard


def _endpoint() -> PlatformEndpoint:
    return PlatformEndpoint(1, swarm="records", incarnation=1, now=0.0, store=MemoryBackupStore())


def _switch(endpoint: PlatformEndpoint, k: int) -> None:
    src, dst = ("A", "B") if k % 2 == 0 else ("B", "A")
    endpoint.engine.transitions.append(
        TransitionRecord(t=float(k), platform=1, src=src, dst=dst, event=f"e{k}", cause="barrier")
    )


def test_every_record_is_logged_once_and_the_engine_keeps_none() -> None:
    endpoint = _endpoint()
    lines: list[tuple[str, dict[str, Any]]] = []
    records = EngineRecords(endpoint.engine, endpoint.runtime, lambda e, **f: lines.append((e, f)))
    assert records.drain() is False and lines == []
    for wake in range(300):  # a switch on every wake, an ignored event on every tenth
        _switch(endpoint, wake)
        if wake % 10 == 0:
            endpoint.engine.ignored.append((float(wake), "nobody_listens", "no transition"))
        if wake == 150:
            endpoint.runtime.failures.append(PluginFailure(150.0, "A", "pilot", "boom"))
        assert records.drain([wake, 0, 0, 0]) is True
        assert endpoint.engine.transitions == [] and endpoint.engine.ignored == []
        assert endpoint.runtime.failures == []
    switches = [f for e, f in lines if e == "transition"]
    assert [f["on"] for f in switches] == [f"e{k}" for k in range(300)]
    assert switches[7]["traffic"] == [7, 0, 0, 0] and switches[7]["frm"] == "B"
    assert [f["at"] for e, f in lines if e == "ignored"] == [float(k) for k in range(0, 300, 10)]
    assert [f for e, f in lines if e == "plugin-failed"] == [
        {"at": 150.0, "actor": "A", "plugin": "pilot", "error": "boom"}
    ]
    assert [r.event for r in records.recent] == [f"e{k}" for k in range(250, 300)]
    assert records.drain() is False


def test_status_shows_the_last_switches(tmp_path: Path) -> None:
    endpoint = _endpoint()
    records = EngineRecords(endpoint.engine, endpoint.runtime, lambda e, **f: None)
    files = DaemonFiles(
        StateDir(tmp_path / "state"),
        endpoint,
        PacketGuard.insecure(),
        Traffic(),
        transitions=records.recent,
    )
    for k in range(120):
        _switch(endpoint, k)
        records.drain()
    files.close(1.0)
    shown = json.loads(files.status_file.read_text())["transitions"]
    assert len(shown) == STATUS_TRANSITIONS == 50
    assert shown[0]["event"] == "e70" and shown[-1]["event"] == "e119"
    assert shown[-1] == {"t": 119.0, "from": "B", "to": "A", "event": "e119", "cause": "barrier"}


def test_status_carries_the_ros2_nodes_counters(tmp_path: Path) -> None:
    endpoint = _endpoint()
    counts = {"keep": 100, "received": 9, "dropped": 4, "undecodable": 1, "readers_dropped": 0}
    said = {"node": "/sw/p1/platform", "alive": True, "errors": 2,
            "topics": {"/sw/p1/detections": counts}}  # fmt: skip
    files = DaemonFiles(
        StateDir(tmp_path / "state"), endpoint, PacketGuard.insecure(), Traffic(), ros2=lambda: said
    )
    files.close(1.0)
    assert json.loads(files.status_file.read_text())["ros2"] == said
    bare = DaemonFiles(StateDir(tmp_path / "bare"), endpoint, PacketGuard.insecure(), Traffic())
    bare.close(1.0)
    assert "ros2" not in json.loads(bare.status_file.read_text())
