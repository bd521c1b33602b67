"""A simulated run recorded as MCAP and read back with the ``mcap`` library's own reader:
every channel checked against the run's report (every transition, every master change,
every platform's entity and transform, map positions, plots' numbers, log lines, metadata
and the script attached), log times never going back; then the project's reader and the
web replay on the same file."""

from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from actorswarm.missions import mission
from actorswarm.recording import TOPICS, read_recording, write_simulation
from actorswarm.recording.recorder import actor_colour
from actorswarm.sim.mission import prepare, run_slices
from actorswarm.sim.tasksim import Fault
from actorswarm.vehicles.mavlink.frame import MissionFrame

MISSION = mission("search-track")
SCRIPT = MISSION.script_path
ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)
KILL = Fault("kill", 15.0, frozenset({1}))
#: The platforms of the run (1 crashes: the report's final actors lack it).
FLEET = {1, 2, 3, 4}


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    """``(recording, report)``: the search-and-track mission on four quadrotors (areas, the
    moving jeep); the master (1) crashes at 15 s, so a second master takes over."""
    packets: list[tuple[float, int]] = []
    sim = prepare(MISSION, platforms=4, kills=((1, KILL.t),), packets=packets)
    report = run_slices(sim, MISSION.duration)
    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    assert sim.world is not None
    write_simulation(
        path,
        report,
        meta={"script": sim.script.name, "seed": 0},
        track=sim.world.track(),
        areas=sim.world.area_polygons(),
        script=(SCRIPT.name, SCRIPT.read_text()),
        packets=packets,
        origin=ORIGIN,
        faults=[KILL],
    )
    return path, report


def _messages(path: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message by topic, ``(log time, decoded JSON)``, in file order; and checks that
    each channel's schema is the one :data:`TOPICS` names, JSON-encoded."""
    out: dict[str, list[tuple[int, Any]]] = defaultdict(list)
    with path.open("rb") as stream:
        reader = make_reader(stream)
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            assert schema is not None and schema.name == TOPICS[channel.topic]
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            json.loads(schema.data)
            out[channel.topic].append((message.log_time, json.loads(message.data)))
    return out


def test_every_channel_is_there_and_time_never_goes_back(
    run: tuple[Path, dict[str, Any]],
) -> None:
    path, _ = run
    last = -1
    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        for _, channel, message in reader.iter_messages(log_time_order=False):
            assert message.log_time >= last, f"{channel.topic} went back in time"
            last = message.log_time
    topics = {c.topic for c in summary.channels.values()}
    assert topics == set(TOPICS)
    stats = summary.statistics.channel_message_counts
    counts = {summary.channels[c].topic: n for c, n in stats.items()}
    assert all(counts.get(topic, 0) > 0 for topic in TOPICS), counts


def test_transitions_masters_and_log_match_the_report(run: tuple[Path, dict[str, Any]]) -> None:
    path, report = run
    got = _messages(path)
    transitions = [body for _, body in got["/actorswarm/transitions"]]
    assert transitions == report["transitions"], "every transition, in order, field for field"
    assert len(report["transitions"]) > 10
    for ns, body in got["/actorswarm/transitions"]:
        assert ns >= round(body["t"] * 1e9), "a fact is never written before it happened"
    masters = [(m["t"], m["masters"], m["epoch"]) for _, m in got["/actorswarm/masters"]]
    assert masters == [(m["t"], [m["platform"]], m["epoch"]) for m in report["masters"]]
    assert len(masters) >= 2 and masters[-1][1] != [1], "a new master after the kill"
    logs = [body for _, body in got["/log"]]
    switches = [line for line in logs if "→" in line["message"]]
    assert len(switches) == len(report["transitions"])
    assert sum(line["message"].startswith("master ") for line in logs) == len(masters)
    for line in logs:
        assert set(line) >= {"timestamp", "level", "message", "name"}
        assert 1 <= line["level"] <= 5


def test_every_platform_has_its_entity_transform_and_map_position(
    run: tuple[Path, dict[str, Any]],
) -> None:
    path, report = run
    got = _messages(path)
    platforms = FLEET
    _, scene = got["/scene"][-1]
    entities = {e["id"]: e for e in scene["entities"]}
    assert set(entities) == {f"platform/{p}" for p in platforms}
    for p, actors in report["final_actors"].items():
        entity = entities[f"platform/{p}"]
        assert entity["frame_id"] == f"platform/{p}" and entity["frame_locked"]
        meta = {kv["key"]: kv["value"] for kv in entity["metadata"]}
        assert meta["actor"] == actors[0]
        r, g, b = actor_colour(actors[0])
        assert entity["arrows"][0]["color"] == {"r": r, "g": g, "b": b, "a": 1.0}
        assert entity["texts"][0]["text"].startswith(f"{p} {actors[0]}")
    framed = {t["child_frame_id"] for _, m in got["/tf"] for t in m["transforms"]}
    assert framed == {f"platform/{p}" for p in platforms}
    fixes = [m for _, m in got["/fix"]]
    assert {m["frame_id"] for m in fixes} == framed
    for fix in fixes:  # the default world spans a few hundred metres around its origin
        assert (
            abs(fix["latitude"] - ORIGIN.lat) < 0.02 and abs(fix["longitude"] - ORIGIN.lon) < 0.03
        )
    trails = got["/trails"][-1][1]["entities"]
    assert {e["id"] for e in trails} == {f"trail/{p}" for p in platforms}
    areas = got["/areas"][0][1]["entities"]
    assert areas and all(e["lines"][0]["points"] for e in areas)
    # The formation's geometry: where each platform is told to be, as the world had it.
    slots = {e["id"]: e for e in got["/formation"][-1][1]["entities"]}
    assert set(slots) == {f"slot/{p}" for p in platforms}
    assert len(got["/formation"]) > 3, "the slots move as the search pattern goes on"


def test_numbers_to_plot(run: tuple[Path, dict[str, Any]]) -> None:
    path, _ = run
    got = _messages(path)
    rows = [row for _, m in got["/platforms"] for row in m["platforms"]]
    assert {"altitude", "speed", "battery", "actor", "mode", "master"} <= set(rows[0])
    assert max(r["altitude"] for r in rows) > 5.0, "they took off"
    assert max(r["speed"] for r in rows) > 1.0
    assert all(0.0 <= r["battery"] <= 1.0 for r in rows)
    metrics = [m for _, m in got["/metrics"]]
    assert any(m.get("packets_per_s", 0) > 0 for m in metrics)
    latencies = [m["barrier_latency_ms"] for m in metrics if "barrier_latency_ms" in m]
    assert latencies and all(ms >= 0 for ms in latencies)
    ups = {m["platforms_up"] for m in metrics if "platforms_up" in m}
    assert ups == {len(FLEET)}, "the simulated fleet, the crashed one included"


def test_the_recording_describes_itself(run: tuple[Path, dict[str, Any]]) -> None:
    path, _ = run
    with path.open("rb") as stream:
        reader = make_reader(stream)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = list(reader.iter_attachments())
    head = metadata["actorswarm"]
    assert head["format"] == "actorswarm" and head["version"] == "2"
    assert json.loads(head["meta"]) == {"script": "search-track-10", "seed": 0}
    assert head["origin"] == f"{ORIGIN.lat},{ORIGIN.lon},{ORIGIN.alt}"
    assert [(a.name, a.media_type) for a in attachments] == [(SCRIPT.name, "application/xml")]
    assert attachments[0].data == SCRIPT.read_bytes()


def test_the_project_reader_and_the_web_replay_show_masters_and_epochs(
    run: tuple[Path, dict[str, Any]],
) -> None:
    from actorswarm.web import ReplaySource

    path, report = run
    data = read_recording(path)
    assert data.notes == []
    assert data.transitions == report["transitions"]
    assert data.meta["script_text"] == SCRIPT.read_text()
    assert set(data.platform.tolist()) == FLEET
    assert set(data.targets) == {"jeep"} and set(data.areas()) == {"search", "field"}
    crashes = [(e["t"], e["platform"]) for e in data.events if e["what"] == "fault"]
    assert (KILL.t, 1) in crashes
    source = ReplaySource(data, playing=False)
    first, second = report["masters"][0], report["masters"][-1]
    source.step(first["t"] + 0.1)
    view = source.swarm_view()
    assert (view["master"], view["epoch"]) == (first["platform"], first["epoch"])
    source.step(second["t"] - source.now() + 0.1)
    view = source.swarm_view()
    assert (view["master"], view["epoch"]) == (second["platform"], second["epoch"])


def test_the_same_run_gives_the_same_file(run: tuple[Path, dict[str, Any]], tmp_path: Path) -> None:
    path, report = run
    again = tmp_path / "again.mcap"
    data = read_recording(path)
    write_simulation(again, report, meta={"seed": 0})
    once_more = tmp_path / "once_more.mcap"
    write_simulation(once_more, report, meta={"seed": 0})
    assert again.read_bytes() == once_more.read_bytes()
    assert read_recording(again).transitions == data.transitions


def test_the_recording_says_how_close_the_vehicles_came(run: tuple[Path, dict[str, Any]]) -> None:
    path, report = run
    separation = report["separation"]
    assert separation["closest"] is not None
    data = read_recording(path)
    said = [e for e in data.events if e["what"] == "separation"]
    closest = separation["closest"]
    a, b = closest["platforms"]
    assert any(
        e["t"] == pytest.approx(closest["t"])
        and f"platforms {a} and {b} {closest['distance_m']:.2f} m" in e["text"]
        for e in said
    ), said
    breaches = [e for e in said if e["text"].startswith("separation breach")]
    assert len(breaches) == len(separation["breaches"])


def test_a_breach_in_a_report_becomes_an_event(tmp_path: Path) -> None:
    report = {
        "transitions": [],
        "masters": [],
        "separation": {
            "breaches": [
                {
                    "platforms": [3, 4],
                    "distance_m": 2.5,
                    "minimum_m": 10.0,
                    "t": 7.0,
                    "start": 6.5,
                    "end": 7.5,
                    "where": [0.0, 0.0, 20.0],
                }
            ],
            "closest": None,
        },
    }
    path = tmp_path / "breach.mcap"
    write_simulation(path, report, meta={"script": "x", "seed": 0})
    events = [e for e in read_recording(path).events if e["what"] == "separation"]
    assert [(e["t"], e["platform"]) for e in events] == [(6.5, 3)]
    assert "platforms 3 and 4 2.50 m apart (minimum 10 m) from 6.5 s to 7.5 s" in events[0]["text"]
