"""The Actor Control Block: validation, step statistics and the status report."""

from __future__ import annotations

import copy
import dataclasses
import json

import pytest

from actorswarm.runtime.acb import (
    ACB,
    PERMISSIONS,
    ActorStatus,
    PluginStepStats,
    Relations,
    RuntimeStats,
    TaskContext,
)
from actorswarm.runtime.operations import Operation, apply


def full_acb() -> ACB:
    """An ACB with every attribute set to something other than its default."""
    acb = ACB(
        name="Track",
        actor_id=3,
        priority=5,
        software=(("observe_bus", "camera.detect"), ("act_bus", "formation.arrow")),
        hardware=frozenset({"camera", "autopilot"}),
        permission="operator-locked",
        context=TaskContext(
            params={"TargetPoint": "200 200 20"},
            group_key=4,
            generation=2,
            index=1,
            data={"targets": [1, 2], "origin": (0.0, 1.5)},
        ),
        relations=Relations(
            group_key=4, generation=2, index=1, transition="AtoB_event", predecessor="Range"
        ),
    )
    apply(acb, Operation.START, 10.0)
    acb.record_step({"camera.detect": 0.002, "formation.arrow": 0.001})
    apply(acb, Operation.FAIL, 12.0, error="camera.detect: lens cap on")
    apply(acb, Operation.START, 13.0)
    return acb


def test_defaults_describe_an_unloaded_normal_actor() -> None:
    acb = ACB(name="A", actor_id=1)
    assert acb.status is ActorStatus.UNLOADED
    assert (acb.priority, acb.software, acb.hardware, acb.permission) == (
        0,
        (),
        frozenset(),
        "normal",
    )
    assert acb.stats == RuntimeStats()
    assert acb.last_error is None


@pytest.mark.parametrize(
    ("kwargs", "complaint"),
    [
        ({"name": "", "actor_id": 1}, "non-empty name"),
        ({"name": "A", "actor_id": -1}, "actor ID must be >= 0"),
        ({"name": "A", "actor_id": 1, "permission": "root"}, "use one of normal"),
    ],
    ids=["empty-name", "negative-id", "unknown-permission"],
)
def test_bad_acb_is_refused_with_a_clear_message(kwargs: dict[str, object], complaint: str) -> None:
    with pytest.raises(ValueError, match=complaint):
        ACB(**kwargs)  # type: ignore[arg-type]


def test_permissions_are_the_documented_ones() -> None:
    assert PERMISSIONS == ("normal", "operator-locked")


def test_context_and_relations_are_frozen() -> None:
    acb = full_acb()
    with pytest.raises(dataclasses.FrozenInstanceError):
        acb.context.index = 9  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        acb.relations.transition = "x"  # type: ignore[misc]


def test_record_step_counts_steps_and_plugin_times() -> None:
    acb = ACB(name="A", actor_id=1)
    apply(acb, Operation.START, 0.0)
    acb.record_step({"p1": 0.5, "p2": 0.25})
    acb.record_step({"p1": 0.25})
    assert acb.stats.steps == 2
    assert acb.stats.plugins["p1"] == PluginStepStats(count=2, total=0.75, max=0.5, last=0.25)
    assert acb.stats.plugins["p1"].mean == pytest.approx(0.375)
    assert acb.stats.plugins["p2"].count == 1


@pytest.mark.parametrize(
    ("status_ops", "times", "complaint"),
    [
        ([], {"p": 0.1}, "not running"),
        ([Operation.START, Operation.PAUSE], {"p": 0.1}, "not running"),
        ([Operation.START], {"ok": 0.1, "p": -1.0}, "'p'"),
        ([Operation.START], {"p": float("nan")}, "'p'"),
    ],
    ids=["unloaded", "sleeping", "negative", "nan"],
)
def test_record_step_refusals_record_nothing(
    status_ops: list[Operation], times: dict[str, float], complaint: str
) -> None:
    acb = ACB(name="A", actor_id=1)
    for i, op in enumerate(status_ops):
        apply(acb, op, float(i))
    before = copy.deepcopy(acb)
    with pytest.raises(ValueError, match=complaint):
        acb.record_step(times)
    assert acb == before


def test_plugin_step_stats_mean_before_any_step() -> None:
    assert PluginStepStats().mean == 0.0


def test_to_status_is_json_and_has_every_attribute() -> None:
    acb = full_acb()
    status = acb.to_status(now=20.0)

    json.dumps(status)  # must not raise
    assert set(status) == {f.name for f in dataclasses.fields(ACB)}
    assert set(status["context"]) == {f.name for f in dataclasses.fields(TaskContext)}
    assert set(status["relations"]) == {f.name for f in dataclasses.fields(Relations)}
    assert set(status["stats"]) == {f.name for f in dataclasses.fields(RuntimeStats)}
    assert set(status["stats"]["plugins"]["camera.detect"]) == {
        *(f.name for f in dataclasses.fields(PluginStepStats)),
        "mean",
    }


def test_to_status_values() -> None:
    status = full_acb().to_status(now=20.0)
    assert status["status"] == "running"
    assert status["hardware"] == ["autopilot", "camera"]
    assert status["software"][0] == {"bus": "observe_bus", "plugin": "camera.detect"}
    assert status["permission"] == "operator-locked"
    assert status["context"]["data"] == {"targets": [1, 2], "origin": [0.0, 1.5]}
    assert status["relations"]["predecessor"] == "Range"
    assert status["last_error"] == "camera.detect: lens cap on"
    stats = status["stats"]
    assert stats["time_running"] == pytest.approx(2.0 + 7.0), "closed 10-12 plus open 13-20"
    assert (stats["start_count"], stats["error_count"], stats["steps"]) == (2, 1, 1)


def test_to_status_without_now_counts_closed_periods_only() -> None:
    assert full_acb().to_status()["stats"]["time_running"] == pytest.approx(2.0)


@pytest.mark.parametrize(
    ("data", "shown"),
    [
        (None, None),
        ({1: {2, 3}}, {"1": repr({2, 3})}),
        (float("inf"), "inf"),
        ([b"raw"], [repr(b"raw")]),
    ],
    ids=["none", "set-in-dict", "infinity", "bytes"],
)
def test_to_status_survives_odd_scattered_data(data: object, shown: object) -> None:
    acb = ACB(name="A", actor_id=1, context=TaskContext(data=data))
    status = acb.to_status()
    json.dumps(status, allow_nan=False)
    assert status["context"]["data"] == shown
