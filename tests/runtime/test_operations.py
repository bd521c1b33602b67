"""The actor state table, its bookkeeping, switch plans and the generated diagram."""

from __future__ import annotations

import copy
import dataclasses
import itertools

import pytest

from actorswarm.runtime.acb import ACB, ActorStatus
from actorswarm.runtime.operations import (
    TRANSITIONS,
    IllegalOperation,
    Operation,
    apply,
    legal_operations,
    mermaid,
    plan_switch,
    switch,
)

S = ActorStatus
Op = Operation

# Written out independently of the module so that a change to the table fails here.
EXPECTED: dict[tuple[ActorStatus, Operation], ActorStatus] = {
    (S.UNLOADED, Op.START): S.RUNNING,
    (S.RUNNING, Op.PAUSE): S.SLEEPING,
    (S.SLEEPING, Op.ACTIVATE): S.RUNNING,
    (S.RUNNING, Op.STOP): S.UNLOADED,
    (S.SLEEPING, Op.STOP): S.UNLOADED,
    (S.ERROR, Op.STOP): S.UNLOADED,
    (S.RUNNING, Op.FAIL): S.ERROR,
    (S.SLEEPING, Op.FAIL): S.ERROR,
    (S.ERROR, Op.START): S.RUNNING,
}
ALL_PAIRS = list(itertools.product(ActorStatus, Operation))
LEGAL = [pair for pair in ALL_PAIRS if pair in EXPECTED]
ILLEGAL = [pair for pair in ALL_PAIRS if pair not in EXPECTED]
COUNTER = {
    Op.START: "start_count",
    Op.STOP: "stop_count",
    Op.PAUSE: "pause_count",
    Op.ACTIVATE: "activate_count",
    Op.FAIL: "error_count",
}


def _ids(pair: tuple[ActorStatus, Operation]) -> str:
    return f"{pair[0].value}-{pair[1].value}"


def acb_in(status: ActorStatus, name: str = "A") -> ACB:
    """An ACB brought to ``status`` by legal operations at t=0 (start) and t=1."""
    acb = ACB(name=name, actor_id=1, priority=2, software=(("act_bus", "core.idle"),))
    if status is not S.UNLOADED:
        apply(acb, Op.START, 0.0)
    if status is S.SLEEPING:
        apply(acb, Op.PAUSE, 1.0)
    elif status is S.ERROR:
        apply(acb, Op.FAIL, 1.0, error="boom")
    assert acb.status is status
    return acb


def test_table_is_exactly_the_designed_one() -> None:
    assert TRANSITIONS == EXPECTED


@pytest.mark.parametrize(("status", "op"), LEGAL, ids=[_ids(p) for p in LEGAL])
def test_legal_operation_changes_status_and_counts_it(status: ActorStatus, op: Operation) -> None:
    acb = acb_in(status)
    before = dataclasses.asdict(acb.stats)

    assert apply(acb, op, 10.0) is EXPECTED[status, op]

    assert acb.status is EXPECTED[status, op]
    after = dataclasses.asdict(acb.stats)
    assert after[COUNTER[op]] == before[COUNTER[op]] + 1, f"{op.value} must count once"
    for other in set(COUNTER.values()) - {COUNTER[op]}:
        assert after[other] == before[other], f"{op.value} must not change {other}"
    assert after["switch_count"] == before["switch_count"], "not part of a switch"
    assert acb.stats.changed_at == 10.0
    if op is Op.START:
        assert acb.stats.started_at == 10.0
    if acb.status is S.RUNNING:
        assert acb.stats.running_since == 10.0
    else:
        assert acb.stats.running_since is None


@pytest.mark.parametrize(("status", "op"), ILLEGAL, ids=[_ids(p) for p in ILLEGAL])
def test_illegal_operation_raises_and_changes_nothing(status: ActorStatus, op: Operation) -> None:
    acb = acb_in(status, name="Survey")
    before = copy.deepcopy(acb)

    with pytest.raises(IllegalOperation) as caught:
        apply(acb, op, 10.0, error="ignored")

    assert acb == before, "an illegal operation must leave the ACB untouched"
    assert dataclasses.asdict(acb) == dataclasses.asdict(before)
    message = str(caught.value)
    assert "'Survey'" in message, message
    assert status.value in message, message
    assert op.value in message, message
    legal = [o for o in Operation if (status, o) in EXPECTED]
    for o in legal:
        assert o.value in message, f"legal {o.value!r} missing from: {message}"
    assert caught.value.legal == tuple(legal)
    assert (caught.value.actor, caught.value.status, caught.value.operation) == (
        "Survey",
        status,
        op,
    )
    assert isinstance(caught.value, ValueError)


@pytest.mark.parametrize("status", list(ActorStatus), ids=lambda s: s.value)
def test_legal_operations_follow_the_table(status: ActorStatus) -> None:
    assert set(legal_operations(status)) == {o for (s, o) in EXPECTED if s is status}


def test_start_from_sleeping_suggests_activate() -> None:
    with pytest.raises(IllegalOperation, match="activate it instead"):
        apply(acb_in(S.SLEEPING), Op.START, 5.0)


def test_time_running_accumulates_only_while_running() -> None:
    acb = ACB(name="A", actor_id=1)
    timeline = [
        (Op.START, 10.0, 0.0),  # (operation, now, time_running after it)
        (Op.PAUSE, 15.0, 5.0),
        (Op.ACTIVATE, 40.0, 5.0),  # 25 s asleep: not counted
        (Op.FAIL, 43.0, 8.0),
        (Op.START, 100.0, 8.0),  # restart after the error; the ERROR time is not counted
        (Op.STOP, 101.5, 9.5),
    ]
    for op, now, expected in timeline:
        apply(acb, op, now)
        assert acb.stats.time_running == pytest.approx(expected), f"after {op.value}@{now}"
    assert acb.stats.running_time(200.0) == pytest.approx(9.5), "unloaded: no open period"


def test_running_time_includes_the_open_period_only_when_asked() -> None:
    acb = ACB(name="A", actor_id=1)
    apply(acb, Op.START, 10.0)
    assert acb.stats.running_time() == 0.0
    assert acb.stats.running_time(12.5) == pytest.approx(2.5)


def test_fail_records_the_error() -> None:
    acb = acb_in(S.RUNNING)
    apply(acb, Op.FAIL, 3.0, error="camera timed out")
    assert acb.last_error == "camera timed out"
    apply(acb, Op.START, 4.0)
    assert acb.last_error == "camera timed out", "kept after a restart for the operator"
    apply(acb, Op.FAIL, 5.0)
    assert acb.last_error is not None and "no message" in acb.last_error


@pytest.mark.parametrize("now", [0.5, float("nan"), float("inf")])
def test_a_clock_that_goes_back_or_is_not_finite_changes_nothing(now: float) -> None:
    acb = acb_in(S.SLEEPING)  # last change at t=1
    before = copy.deepcopy(acb)
    with pytest.raises(ValueError, match="now"):
        apply(acb, Op.ACTIVATE, now)
    assert acb == before


def test_the_same_instant_is_allowed() -> None:
    acb = acb_in(S.SLEEPING)
    apply(acb, Op.ACTIVATE, 1.0)
    assert acb.status is S.RUNNING


# (current status, target status or None, expected plan as (name, operation))
SWITCH_PLANS = [
    (S.RUNNING, S.SLEEPING, [("A", Op.PAUSE), ("B", Op.ACTIVATE)]),
    (S.RUNNING, S.UNLOADED, [("A", Op.PAUSE), ("B", Op.START)]),
    (S.RUNNING, S.ERROR, [("A", Op.PAUSE), ("B", Op.START)]),
    (S.RUNNING, S.RUNNING, [("A", Op.PAUSE)]),
    (S.RUNNING, None, [("A", Op.PAUSE)]),
    (S.SLEEPING, S.UNLOADED, [("B", Op.START)]),
    (S.ERROR, S.SLEEPING, [("B", Op.ACTIVATE)]),
    (S.UNLOADED, S.UNLOADED, [("B", Op.START)]),
]


@pytest.mark.parametrize(
    ("current", "target", "plan"),
    SWITCH_PLANS,
    ids=[f"{c.value}-to-{t.value if t else 'nothing'}" for c, t, _ in SWITCH_PLANS],
)
def test_plan_switch(
    current: ActorStatus, target: ActorStatus | None, plan: list[tuple[str, Operation]]
) -> None:
    a = acb_in(current, "A")
    b = acb_in(target, "B") if target is not None else None
    assert plan_switch(a, b) == plan


def test_switch_to_itself_is_empty() -> None:
    a = acb_in(S.RUNNING)
    assert plan_switch(a, a) == []
    assert switch(a, a, 5.0) == []
    assert a.status is S.RUNNING


def test_switch_reactivates_a_sleeping_target_instead_of_reloading_it() -> None:
    a = acb_in(S.RUNNING, "A")
    b = acb_in(S.SLEEPING, "B")

    plan = switch(a, b, 7.0)

    assert plan == [("A", Op.PAUSE), ("B", Op.ACTIVATE)]
    assert (a.status, b.status) == (S.SLEEPING, S.RUNNING)
    assert b.stats.start_count == 1, "re-activated, not started again"
    assert b.stats.activate_count == 1
    assert (a.stats.switch_count, b.stats.switch_count) == (1, 1)
    assert a.stats.time_running == pytest.approx(7.0)


def test_switch_starts_an_unloaded_target() -> None:
    a = acb_in(S.RUNNING, "A")
    b = acb_in(S.UNLOADED, "B")
    switch(a, b, 3.0)
    assert (b.status, b.stats.start_count, b.stats.started_at) == (S.RUNNING, 1, 3.0)


def test_switch_checks_the_clock_of_both_before_changing_either() -> None:
    a = acb_in(S.RUNNING, "A")  # last change at t=0
    b = acb_in(S.SLEEPING, "B")  # last change at t=1
    before = copy.deepcopy((a, b))
    with pytest.raises(ValueError, match="'B'"):
        switch(a, b, 0.5)
    assert (a, b) == before


def test_mermaid_draws_every_transition() -> None:
    diagram = mermaid()
    assert diagram.startswith("stateDiagram-v2\n")
    assert "[*] --> unloaded" in diagram
    for (src, op), dst in EXPECTED.items():
        assert f"{src.value} --> {dst.value}: {op.value}" in diagram
    assert diagram.count("-->") == len(EXPECTED) + 1
