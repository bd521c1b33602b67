"""Run recordings (JSON Lines) and the pictures drawn from them."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from actorswarm.dsl import load
from actorswarm.sim.record import (
    RecordError,
    actor_timeline,
    collective_transitions,
    read_record,
    sample_world,
    write_record,
)
from actorswarm.sim.tasksim import TaskSim
from actorswarm.viz import timeline_png, trajectory_png
from actorswarm.world.config import load_world

ROOT = Path(__file__).resolve().parents[2]
PNG = b"\x89PNG\r\n\x1a\n"

Row = tuple[float, int, float, float, float, float, str]


def _synthetic() -> tuple[list[Row], list[dict[str, Any]]]:
    """Three platforms flying east along parallel lines for 10 s; all switch A → B at t=5
    (a few ms apart), and platform 3 also runs C from t=7."""
    rows: list[Row] = []
    for k in range(21):
        t = k * 0.5
        for p in (1, 2, 3):
            rows.append((t, p, 3.0 * t, 10.0 * p, 20.0, 0.0, "flying"))
    transitions: list[dict[str, Any]] = []
    for p in (1, 2, 3):
        transitions.append(
            {"t": 0.0, "platform": p, "from": "", "to": "A", "event": "", "cause": "start"}
        )
    for p in (1, 2, 3):
        transitions.append(
            {
                "t": 5.0 + 0.002 * p,
                "platform": p,
                "from": "A",
                "to": "B",
                "event": "go",
                "cause": "barrier",
            }
        )
    transitions.append(
        {"t": 7.0, "platform": 3, "from": "", "to": "C", "event": "extra", "cause": "branch"}
    )
    return rows, transitions


def _is_png(path: Path) -> bool:
    data = path.read_bytes()
    return data.startswith(PNG) and len(data) > 10_000


# --- the file ------------------------------------------------------------------------------


def test_round_trip_is_identical(tmp_path: Path) -> None:
    rows, transitions = _synthetic()
    meta = {"script": "lines", "seed": 7, "duration": 10.0}
    path = tmp_path / "run.jsonl"
    write_record(path, rows=rows, transitions=transitions, meta=meta)

    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert lines[0]["type"] == "meta"
    assert [line["type"] for line in lines[1:]] == ["pose"] * len(rows) + ["transition"] * len(
        transitions
    )

    rec = read_record(path)
    assert rec.meta == meta
    assert rec.rows() == rows
    assert rec.transitions == transitions
    assert len(rec) == len(rows)
    assert rec.t.dtype == np.float64 and rec.platform.dtype == np.int64
    assert rec.platforms() == [1, 2, 3]
    times, xyz = rec.path(2)
    assert times.tolist() == [k * 0.5 for k in range(21)]
    assert xyz.shape == (21, 3) and set(xyz[:, 1].tolist()) == {20.0}
    assert rec.end_time() == 10.0


def test_write_refuses_reserved_meta_and_non_finite(tmp_path: Path) -> None:
    path = tmp_path / "bad.jsonl"
    with pytest.raises(ValueError, match="reserved"):
        write_record(path, rows=[], transitions=[], meta={"type": "x"})
    with pytest.raises(ValueError, match="cannot record"):
        write_record(
            path, rows=[(0.0, 1, math.nan, 0.0, 0.0, 0.0, "ground")], transitions=[], meta={}
        )
    assert not path.exists() and not list(tmp_path.iterdir())  # no half-written file left


def _write_lines(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n")
    return path


META = '{"type": "meta", "format": "actorswarm-record", "version": 1}'
POSE = '{"type": "pose", "t": 0, "platform": 1, "x": 0, "y": 0, "z": 0, "heading": 0, "mode": "g"}'
TRANSITION = (
    '{"type": "transition", "t": 1, "platform": 1, "from": "", "to": "A", "event": "", '
    '"cause": "start"}'
)


@pytest.mark.parametrize(
    ("lines", "lineno", "words"),
    [
        ([], 1, "empty recording"),
        ([POSE], 1, "meta line"),
        ([META, POSE, "{not json"], 3, "not JSON"),
        ([META, "[1, 2]"], 2, "JSON object"),
        ([META, POSE, '{"type": "wind"}'], 3, "unknown type"),
        ([META, POSE.replace('"x": 0', '"x": "east"')], 2, "'x'"),
        ([META, POSE.replace('"platform": 1', '"platform": 1.5')], 2, "'platform'"),
        ([META, POSE.replace('"platform": 1', '"platform": true')], 2, "'platform'"),
        ([META, POSE.replace('"t": 0', '"t": NaN')], 2, "'t'"),
        ([META, POSE.replace(', "mode": "g"', "")], 2, "'mode'"),
        ([META, POSE, POSE, TRANSITION.replace('"to": "A"', '"to": 3')], 4, "'to'"),
        ([META, TRANSITION.replace('"t": 1, ', "")], 2, "'t'"),
        ([META, "", META], 3, "second meta"),
        ([META.replace('"version": 1', '"version": 2')], 1, "version"),
        ([META.replace("actorswarm-record", "other")], 1, "format"),
        ([META, '{"type": "target", "t": 0, "name": "j", "x": 0, "y": "n", "z": 0}'], 2, "'y'"),
        ([META, '{"type": "target", "t": 0, "name": 3, "x": 0, "y": 0, "z": 0}'], 2, "'name'"),
    ],
)
def test_malformed_files_are_refused_with_the_line(
    tmp_path: Path, lines: list[str], lineno: int, words: str
) -> None:
    path = _write_lines(tmp_path / "bad.jsonl", lines)
    with pytest.raises(RecordError, match=f"line {lineno}:.*{words}") as info:
        read_record(path)
    assert isinstance(info.value, ValueError)
    assert str(path) in str(info.value)


def test_blank_lines_are_skipped(tmp_path: Path) -> None:
    rec = read_record(_write_lines(tmp_path / "ok.jsonl", [META, "", POSE, "  ", TRANSITION]))
    assert len(rec) == 1 and len(rec.transitions) == 1 and rec.meta == {}


# --- analysis ------------------------------------------------------------------------------


def test_actor_timeline() -> None:
    _, transitions = _synthetic()
    assert actor_timeline(transitions) == [
        (1, "A", 0.0, 5.002),
        (1, "B", 5.002, None),
        (2, "A", 0.0, 5.004),
        (2, "B", 5.004, None),
        (3, "A", 0.0, 5.006),
        (3, "B", 5.006, None),
        (3, "C", 7.0, None),
    ]


def test_actor_timeline_stops_restarts_and_unordered_input() -> None:
    def tr(t: float, src: str, dst: str) -> dict[str, Any]:
        return {"t": t, "platform": 4, "from": src, "to": dst, "event": "", "cause": "x"}

    rows = [tr(9.0, "B", ""), tr(2.0, "A", "A"), tr(1.0, "", "A"), tr(4.0, "A", "B")]
    assert actor_timeline(rows) == [
        (4, "A", 1.0, 2.0),
        (4, "A", 2.0, 4.0),  # a self-transition restarts the actor
        (4, "B", 4.0, 9.0),  # an empty "to" stops it
    ]
    # a stop without a start (recording begun mid-run) counts from the first transition
    assert actor_timeline([tr(3.0, "", "X"), tr(5.0, "Y", "")]) == [
        (4, "X", 3.0, None),
        (4, "Y", 3.0, 5.0),
    ]
    assert actor_timeline([]) == []


def test_collective_transitions() -> None:
    _, transitions = _synthetic()
    found = collective_transitions(transitions)
    assert len(found) == 1  # the starts and platform 3's lone C are not collective
    (go,) = found
    assert (go.event, go.src, go.dst, go.cause, go.platforms) == (
        "go",
        "A",
        "B",
        "barrier",
        (1, 2, 3),
    )
    assert go.t == 5.002 and go.t_last == 5.006 and go.label == "go"
    assert collective_transitions(transitions, fleet=10) == []  # 3 of 10 is not many


# --- pictures ------------------------------------------------------------------------------


def test_pictures_of_synthetic_run(tmp_path: Path) -> None:
    rows, transitions = _synthetic()
    path = tmp_path / "run.jsonl"
    write_record(path, rows=rows, transitions=transitions, meta={"script": "lines"})
    rec = read_record(path)
    traj = trajectory_png(rec, tmp_path / "pics" / "trajectory.png")
    line = timeline_png(rec, tmp_path / "pics" / "timeline.png")
    assert traj == tmp_path / "pics" / "trajectory.png"
    assert line == tmp_path / "pics" / "timeline.png"
    assert _is_png(traj) and _is_png(line)


def test_pictures_of_an_empty_recording(tmp_path: Path) -> None:
    path = tmp_path / "empty.jsonl"
    write_record(path, rows=[], transitions=[], meta={})
    rec = read_record(path)
    for out in (trajectory_png(rec, tmp_path / "t.png"), timeline_png(rec, tmp_path / "l.png")):
        assert out.read_bytes().startswith(PNG)


def test_sample_world_needs_a_world() -> None:
    sim = TaskSim(load(ROOT / "examples" / "branch_merge.xml"))
    with pytest.raises(ValueError, match="no world"):
        sample_world(sim, 0.5)


def test_end_to_end_takeoff_ingress_return(tmp_path: Path) -> None:
    world = load_world(ROOT / "examples" / "worlds" / "default.toml")
    sim = TaskSim(load(ROOT / "examples" / "takeoff_ingress_return.xml"), world_config=world)
    with pytest.raises(ValueError, match="> 0"):
        sample_world(sim, 0.0)
    sample_world(sim, 0.5)
    report = sim.run(60.0)
    assert sim.world is not None
    track = sim.world.track()
    assert track.times.tolist() == [k * 0.5 for k in range(121)]

    path = tmp_path / "run.jsonl"
    meta = {"script": "takeoff-ingress-return", "seed": sim.seed, "duration": 60.0}
    write_record(path, rows=track.rows(), transitions=report["transitions"], meta=meta)
    rec = read_record(path)
    assert rec.meta == meta
    assert rec.rows() == list(track.rows())
    assert rec.transitions == report["transitions"]
    assert rec.platforms() == list(range(1, 11))
    assert float(rec.z.max()) > 15.0  # they flew

    moves = [(c.src, c.dst, len(c.platforms)) for c in collective_transitions(rec.transitions)]
    assert moves == [("Standby", "Ingress", 10), ("Ingress", "Return", 10)]
    spans = actor_timeline(rec.transitions)
    assert sorted({actor for _, actor, _, _ in spans}) == ["Ingress", "Return", "Standby"]
    assert all(end is None for _, actor, _, end in spans if actor == "Return")

    traj = trajectory_png(rec, tmp_path / "trajectory.png")
    line = timeline_png(rec, tmp_path / "timeline.png")
    assert _is_png(traj) and _is_png(line)


def test_targets_and_areas_round_trip_and_are_drawn(tmp_path: Path) -> None:
    rows, transitions = _synthetic()
    targets = [(float(t), "jeep", 10.0 + t, 5.0, 0.0) for t in (2.0, 0.0, 1.0)]
    path = tmp_path / "run.jsonl"
    areas = {"search": [[0.0, 0.0], [50.0, 0.0], [50.0, 40.0]], "bad": "not a polygon"}
    write_record(path, rows=rows, transitions=transitions, meta={"areas": areas}, targets=targets)
    rec = read_record(path)
    times, xyz = rec.targets["jeep"]
    assert times.tolist() == [0.0, 1.0, 2.0], "sorted by time"
    assert xyz[:, 0].tolist() == [10.0, 11.0, 12.0]
    assert rec.areas() == {"search": [(0.0, 0.0), (50.0, 0.0), (50.0, 40.0)]}, "bad skipped"
    assert _is_png(trajectory_png(rec, tmp_path / "t.png"))
