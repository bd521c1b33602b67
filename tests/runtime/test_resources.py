"""Exclusive hardware resources: grants, preemption by priority, refusals and resumption."""

from __future__ import annotations

import copy
import random

import pytest
from hypothesis import given
from hypothesis import strategies as st

from actorswarm.runtime.resources import Grant, ResourceArbiter, ResourceBusy


def fs(*names: str) -> frozenset[str]:
    return frozenset(names)


def snapshot(arbiter: ResourceArbiter) -> dict[str, object]:
    """Everything observable about an arbiter, to show that a call changed nothing."""
    return copy.deepcopy(
        {"holders": arbiter.holders(), "waiting": arbiter.waiting(), "internals": vars(arbiter)}
    )


def test_disjoint_sets_are_granted_to_several_actors() -> None:
    arb = ResourceArbiter()
    assert arb.acquire("fly", 0, fs("autopilot")) == Grant(actor="fly", resources=fs("autopilot"))
    assert arb.acquire("film", 0, fs("camera", "gimbal")).preempted == ()
    assert arb.acquire("listen", 0, fs("radio-scanner")).preempted == ()
    assert arb.holders() == {
        "autopilot": "fly",
        "camera": "film",
        "gimbal": "film",
        "radio-scanner": "listen",
    }
    assert arb.held_by("film") == fs("camera", "gimbal")


def test_higher_priority_preempts_lower_and_lower_resumes_on_release() -> None:
    arb = ResourceArbiter()
    arb.acquire("survey", 1, fs("autopilot", "camera"))

    grant = arb.acquire("track", 5, fs("camera"))

    assert grant.preempted == ("survey",), "the caller must pause survey"
    assert arb.holders() == {"camera": "track"}, "survey lost everything, autopilot too"
    assert arb.waiting() == {"survey": fs("autopilot", "camera")}

    assert arb.release("track") == ["survey"]
    assert arb.holders() == {"autopilot": "survey", "camera": "survey"}, "re-granted"
    assert arb.waiting() == {}


@pytest.mark.parametrize("caller_priority", [5, 4], ids=["equal", "lower"])
def test_equal_or_lower_priority_is_refused_naming_the_holder(caller_priority: int) -> None:
    arb = ResourceArbiter()
    arb.acquire("track", 5, fs("camera"))
    before = snapshot(arb)

    with pytest.raises(ResourceBusy) as caught:
        arb.acquire("survey", caller_priority, fs("camera"))

    err = caught.value
    assert (err.resource, err.holder, err.holder_priority) == ("camera", "track", 5)
    message = str(err)
    for part in ("'survey'", "'camera'", "'track'", "priority 5", "above 5"):
        assert part in message, f"{part} missing from: {message}"
    assert isinstance(err, ValueError)
    assert snapshot(arb) == before


def test_partial_availability_refuses_without_preempting_anyone() -> None:
    arb = ResourceArbiter()
    arb.acquire("low", 1, fs("camera"))
    arb.acquire("high", 9, fs("autopilot"))
    before = snapshot(arb)

    # camera alone could be preempted, but autopilot cannot: nothing must happen.
    with pytest.raises(ResourceBusy) as caught:
        arb.acquire("mid", 5, fs("camera", "autopilot"))

    assert (caught.value.resource, caught.value.holder) == ("autopilot", "high")
    assert caught.value.blocking == (("autopilot", "high", 9),)
    assert snapshot(arb) == before
    assert arb.holders() == {"autopilot": "high", "camera": "low"}


def test_refusal_lists_every_blocking_holder() -> None:
    arb = ResourceArbiter()
    arb.acquire("a", 7, fs("camera"))
    arb.acquire("b", 9, fs("autopilot"))
    with pytest.raises(ResourceBusy) as caught:
        arb.acquire("c", 3, fs("camera", "autopilot"))
    assert caught.value.blocking == (("autopilot", "b", 9), ("camera", "a", 7))
    assert "above 9" in str(caught.value)


@pytest.mark.parametrize("who", ["never-seen", "holds-nothing"])
def test_release_of_an_actor_holding_nothing_is_harmless(who: str) -> None:
    arb = ResourceArbiter()
    arb.acquire("fly", 0, fs("autopilot"))
    arb.acquire("holds-nothing", 0, fs())
    before = snapshot(arb)
    assert arb.release(who) == []
    assert arb.release(who) == []
    assert snapshot(arb) == before


def test_release_forgets_a_waiting_actor() -> None:
    arb = ResourceArbiter()
    arb.acquire("low", 1, fs("camera"))
    arb.acquire("high", 5, fs("camera"))
    assert arb.release("low") == [], "stopped while preempted: never resumed"
    assert arb.release("high") == []
    assert arb.holders() == {}


def test_chained_preemption_resumes_in_reverse() -> None:
    arb = ResourceArbiter()
    arb.acquire("p1", 1, fs("autopilot"))
    assert arb.acquire("p5", 5, fs("autopilot")).preempted == ("p1",)
    assert arb.acquire("p9", 9, fs("autopilot")).preempted == ("p5",)
    assert arb.waiting() == {"p1": fs("autopilot"), "p5": fs("autopilot")}

    assert arb.release("p9") == ["p5"], "higher priority first; p1 still blocked by p5"
    assert arb.holders() == {"autopilot": "p5"}
    assert arb.release("p5") == ["p1"]
    assert arb.holders() == {"autopilot": "p1"}


def test_resume_order_is_priority_then_preemption_order() -> None:
    arb = ResourceArbiter()
    arb.acquire("a", 1, fs("x"))
    arb.acquire("b", 3, fs("y"))
    arb.acquire("c", 1, fs("z"))
    grant = arb.acquire("boss", 9, fs("x", "y", "z"))
    assert grant.preempted == ("a", "b", "c"), "in sorted resource order"
    assert arb.release("boss") == ["b", "a", "c"]


def test_waiting_actors_compete_for_freed_resources_by_priority() -> None:
    arb = ResourceArbiter()
    arb.acquire("low", 1, fs("camera"))
    arb.acquire("mid", 3, fs("camera", "gimbal"))  # preempts low
    arb.acquire("top", 9, fs("camera", "gimbal"))  # preempts mid
    assert arb.release("top") == ["mid"], "mid outranks low for the camera"
    assert arb.waiting() == {"low": fs("camera")}


def test_one_caller_preempting_two_holders_of_one_actor_lists_it_once() -> None:
    arb = ResourceArbiter()
    arb.acquire("low", 1, fs("camera", "gimbal"))
    assert arb.acquire("high", 2, fs("camera", "gimbal")).preempted == ("low",)


def test_leftovers_of_a_preempted_holder_resume_a_waiter_at_once() -> None:
    arb = ResourceArbiter()
    arb.acquire("w", 1, fs("c"))
    arb.acquire("p", 5, fs("a", "c"))  # w waits for c
    grant = arb.acquire("h", 9, fs("a"))  # p loses a and c; c is free for w
    assert grant.preempted == ("p",)
    assert grant.resumed == ("w",)
    assert arb.holders() == {"a": "h", "c": "w"}
    assert arb.waiting() == {"p": fs("a", "c")}


def test_a_waiting_actor_may_compete_again() -> None:
    arb = ResourceArbiter()
    arb.acquire("low", 1, fs("camera"))
    arb.acquire("mid", 5, fs("camera"))
    with pytest.raises(ResourceBusy):
        arb.acquire("low", 1, fs("camera"))
    assert arb.waiting() == {"low": fs("camera")}, "a refusal keeps it waiting"
    assert arb.acquire("low", 7, fs("camera")).preempted == ("mid",)
    assert arb.waiting() == {"mid": fs("camera")}


@pytest.mark.parametrize(
    ("call", "error", "complaint"),
    [
        (lambda a: a.acquire("fly", 0, fs("camera")), ValueError, "already holds 'autopilot'"),
        (lambda a: a.acquire("", 0, fs("camera")), ValueError, "actor name"),
        (lambda a: a.acquire("x", 0, fs("")), ValueError, "non-empty"),
        (lambda a: a.acquire("x", 0, "camera"), TypeError, "not a string"),
    ],
    ids=["already-holding", "no-name", "empty-resource", "bare-string"],
)
def test_misuse_is_refused_and_changes_nothing(
    call: object, error: type[Exception], complaint: str
) -> None:
    arb = ResourceArbiter()
    arb.acquire("fly", 0, fs("autopilot"))
    before = snapshot(arb)
    with pytest.raises(error, match=complaint):
        call(arb)  # type: ignore[operator]
    assert snapshot(arb) == before


ACTORS = [f"actor{i}" for i in range(6)]
RESOURCES = ["autopilot", "camera", "gimbal", "radio"]


@given(st.integers(min_value=0, max_value=2**32 - 1))
def test_random_calls_keep_the_invariants(seed: int) -> None:
    """Whatever happens: a resource has one holder, holders hold all they asked for, and
    after every call no waiting actor could be resumed."""
    rng = random.Random(seed)
    arb = ResourceArbiter()
    for _ in range(40):
        actor = rng.choice(ACTORS)
        if rng.random() < 0.6:
            needs = frozenset(rng.sample(RESOURCES, rng.randint(1, 3)))
            try:
                arb.release(actor)
                arb.acquire(actor, rng.randint(0, 3), needs)
            except ResourceBusy:
                pass
            else:
                assert arb.held_by(actor) == needs, f"seed {seed}"
        else:
            arb.release(actor)
        holders = arb.holders()
        for res, who in holders.items():
            assert res in arb.held_by(who), f"seed {seed}: {res} held by {who}"
        for who, needs in arb.waiting().items():
            assert arb.held_by(who) == frozenset(), f"seed {seed}: {who} waits and holds"
            assert needs & holders.keys(), f"seed {seed}: {who} could resume but waits"
