"""The discrete-event scheduler: order, ties, cancellation, virtual time."""

from __future__ import annotations

import gc

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from actorswarm.sim.scheduler import RUN_GC_THRESHOLDS, Scheduler


def test_starts_at_zero_and_empty() -> None:
    sched = Scheduler()
    assert sched.now == 0.0
    assert sched.pending == 0
    assert sched.next_time() is None
    assert sched.run_next() is False


def test_events_run_in_time_order() -> None:
    sched = Scheduler()
    log: list[tuple[float, str]] = []
    for t, name in [(3.0, "c"), (1.0, "a"), (2.0, "b")]:
        sched.at(t, lambda n=name: log.append((sched.now, n)))
    sched.run_until(10.0)
    assert log == [(1.0, "a"), (2.0, "b"), (3.0, "c")]
    assert sched.now == 10.0


def test_ties_run_in_insertion_order() -> None:
    sched = Scheduler()
    log: list[int] = []
    for i in range(20):
        sched.at(1.0, log.append, i)
    sched.call_at(1.0, log.append, 20)
    sched.after(1.0, log.append, 21)
    sched.run_until(1.0)
    assert log == list(range(22))


def test_arguments_are_passed() -> None:
    sched = Scheduler()
    got: list[tuple[int, str]] = []
    sched.at(0.5, lambda a, b: got.append((a, b)), 7, "x")
    sched.call_after(0.5, lambda a, b: got.append((a, b)), 8, "y")
    sched.run_until(1.0)
    assert got == [(7, "x"), (8, "y")]


def test_run_until_stops_at_t_inclusive_and_sets_now() -> None:
    sched = Scheduler()
    log: list[float] = []
    for t in (1.0, 2.0, 2.5, 3.0):
        sched.at(t, lambda: log.append(sched.now))
    sched.run_until(2.5)
    assert log == [1.0, 2.0, 2.5]
    assert sched.now == 2.5
    assert sched.pending == 1
    sched.run_until(2.7)
    assert sched.now == 2.7
    assert log == [1.0, 2.0, 2.5]
    sched.run_until(3.0)
    assert log == [1.0, 2.0, 2.5, 3.0]


def test_events_scheduled_by_events_run_in_the_same_call() -> None:
    sched = Scheduler()
    log: list[tuple[float, str]] = []

    def first() -> None:
        log.append((sched.now, "first"))
        sched.after(0.0, lambda: log.append((sched.now, "same time")))
        sched.after(0.5, lambda: log.append((sched.now, "later")))
        sched.after(5.0, lambda: log.append((sched.now, "too late")))

    sched.at(1.0, first)
    sched.at(1.0, lambda: log.append((sched.now, "tie")))
    sched.run_until(2.0)
    assert log == [(1.0, "first"), (1.0, "tie"), (1.0, "same time"), (1.5, "later")]
    assert sched.pending == 1


def test_scheduling_in_the_past_is_refused() -> None:
    sched = Scheduler()
    sched.run_until(5.0)
    with pytest.raises(ValueError, match="cannot schedule"):
        sched.at(4.9, print)
    with pytest.raises(ValueError, match="cannot schedule"):
        sched.call_at(1.0, print)
    with pytest.raises(ValueError, match="delay"):
        sched.after(-0.1, print)
    with pytest.raises(ValueError, match="delay"):
        sched.call_after(-1.0, print)
    with pytest.raises(ValueError):
        sched.at(float("nan"), print)
    with pytest.raises(ValueError):
        sched.at(float("inf"), print)
    with pytest.raises(ValueError, match="cannot run until"):
        sched.run_until(4.0)
    sched.at(5.0, print)  # the present is allowed
    assert sched.pending == 1


def test_cancel() -> None:
    sched = Scheduler()
    log: list[str] = []
    keep = sched.at(1.0, log.append, "keep")
    drop = sched.at(1.0, log.append, "drop")
    assert sched.pending == 2
    drop.cancel()
    drop.cancel()  # idempotent
    assert drop.cancelled
    assert not drop.active
    assert sched.pending == 1
    sched.run_until(2.0)
    assert log == ["keep"]
    assert keep.fired
    assert not drop.fired
    assert sched.pending == 0


def test_cancel_after_firing_is_a_noop() -> None:
    sched = Scheduler()
    log: list[int] = []
    timer = sched.at(1.0, log.append, 1)
    sched.run_until(1.0)
    assert timer.fired
    timer.cancel()
    assert not timer.cancelled
    assert sched.pending == 0
    # A later event at the same time is still cancellable.
    later = sched.at(1.0, log.append, 2)
    assert later.active
    later.cancel()
    sched.run_until(3.0)
    assert log == [1]
    assert sched.pending == 0


def test_an_event_can_cancel_a_later_one_at_the_same_time() -> None:
    sched = Scheduler()
    log: list[str] = []
    victim = sched.at(1.0, log.append, "victim")
    sched.at(0.5, victim.cancel)
    sched.at(1.0, log.append, "other")
    sched.run_until(1.0)
    assert log == ["other"]


def test_run_next_skips_cancelled_and_advances_time() -> None:
    sched = Scheduler()
    log: list[float] = []
    sched.at(1.0, lambda: log.append(sched.now)).cancel()
    sched.at(2.0, lambda: log.append(sched.now))
    assert sched.next_time() == 2.0
    assert sched.run_next() is True
    assert log == [2.0]
    assert sched.now == 2.0
    assert sched.run_next() is False
    assert sched.now == 2.0


def test_reentrant_run_is_refused() -> None:
    sched = Scheduler()
    errors: list[Exception] = []

    def nested() -> None:
        try:
            sched.run_until(sched.now + 1.0)
        except RuntimeError as exc:
            errors.append(exc)

    sched.at(1.0, nested)
    sched.run_until(2.0)
    assert len(errors) == 1


def test_exception_propagates_and_scheduler_stays_usable() -> None:
    sched = Scheduler()
    log: list[int] = []

    def boom() -> None:
        raise KeyError("boom")

    sched.at(1.0, boom)
    sched.at(2.0, log.append, 2)
    with pytest.raises(KeyError):
        sched.run_until(3.0)
    assert sched.now == 1.0
    sched.run_until(3.0)
    assert log == [2]
    assert sched.now == 3.0


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(min_value=0, max_value=5), st.booleans()),
        min_size=0,
        max_size=40,
    )
)
def test_order_matches_a_stable_sort(plan: list[tuple[int, bool]]) -> None:
    """Whatever the schedule: (time, insertion) order, cancelled events absent."""
    sched = Scheduler()
    log: list[int] = []
    timers = [sched.at(float(t), log.append, i) for i, (t, _) in enumerate(plan)]
    for timer, (_, cancel) in zip(timers, plan, strict=True):
        if cancel:
            timer.cancel()
    expected = [
        i for i, (_, cancel) in sorted(enumerate(plan), key=lambda e: e[1][0]) if not cancel
    ]
    assert sched.pending == len(expected)
    sched.run_until(5.0)
    assert log == expected
    assert sched.pending == 0


def test_the_collector_runs_rarely_during_a_run_and_as_before_after_it() -> None:
    sched = Scheduler()
    seen: list[tuple[int, int, int]] = []
    before = gc.get_threshold()

    def boom() -> None:
        seen.append(gc.get_threshold())
        raise RuntimeError("boom")

    sched.call_at(1.0, lambda: seen.append(gc.get_threshold()))
    sched.run_until(2.0)
    assert seen == [RUN_GC_THRESHOLDS] and gc.get_threshold() == before
    sched.call_at(3.0, boom)
    with pytest.raises(RuntimeError):
        sched.run_until(4.0)
    assert seen[-1] == RUN_GC_THRESHOLDS and gc.get_threshold() == before
