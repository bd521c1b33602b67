"""The smallest fault schedule that still fails the same way: delta debugging.

Zeller and Hildebrandt's *ddmin* ("Simplifying and Isolating Failure-Inducing Input",
2002) over a schedule's items: try halves, then quarters… of the faults, and their
complements, keeping any subset that still fails with the *same signature* (so the search
does not wander to another failure); stop when no single item can be taken away. Every
test is a full, deterministic re-run of the simulation (:func:`~.runner.run_one`), so the
result is *1-minimal*: each fault it keeps is needed for that failure. ``budget`` caps the
re-runs; when it runs out the smallest failing schedule found so far is returned, and
:class:`Minimized` says it was cut short.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

from actorswarm.sim.verify.runner import Mission, RunResult, run_one
from actorswarm.sim.verify.schedule import Item, Schedule

__all__ = ["DEFAULT_BUDGET", "Minimized", "ddmin", "minimize"]

#: Re-runs spent at most on one failure class.
DEFAULT_BUDGET = 48

T = TypeVar("T")


def ddmin(
    items: Sequence[T], fails: Callable[[list[T]], bool], budget: int = DEFAULT_BUDGET
) -> tuple[list[T], int, bool]:
    """A 1-minimal subset of ``items`` (in their order) for which ``fails`` holds, given
    that it holds for all of them: ``(subset, tests run, complete)``; ``complete`` is False
    when ``budget`` tests ran out first (the subset then still fails, but may not be
    minimal). The empty subset is tried first: a failure with no fault at all."""
    tests = 0
    exhausted = False
    seen: dict[tuple[int, ...], bool] = {}

    def test(subset: list[int]) -> bool:
        # A test the budget no longer allows counts as "passes": nothing is taken away.
        nonlocal tests, exhausted
        key = tuple(subset)
        if key not in seen:
            if tests >= budget:
                exhausted = True
                return False
            tests += 1
            seen[key] = fails([items[i] for i in subset])
        return seen[key]

    if not items or test([]):
        return [], tests, True
    current, n = list(range(len(items))), 2
    while len(current) >= 2 and not exhausted:
        size = len(current) / n
        chunks = [current[round(k * size) : round((k + 1) * size)] for k in range(n)]
        chunks = [c for c in chunks if c]
        reduced = next((c for c in chunks if test(c)), None)
        if reduced is not None:
            current, n = reduced, 2
            continue
        # With two chunks each complement is the other chunk, already tried.
        complements = [[i for i in current if i not in c] for c in chunks] if n > 2 else []
        reduced = next((r for r in complements if test(r)), None)
        if reduced is not None:
            current, n = reduced, max(n - 1, 2)
        elif n >= len(current):
            break
        else:
            n = min(len(current), 2 * n)
    return [items[i] for i in current], tests, not exhausted


@dataclass(frozen=True, slots=True)
class Minimized:
    """A failure class's smallest failing schedule and its run."""

    schedule: Schedule
    result: RunResult
    #: How many faults the run that was minimized had.
    original: int
    reruns: int
    #: False when the re-run budget ran out before the schedule was 1-minimal.
    complete: bool


def minimize(
    mission: Mission, schedule: Schedule, signature: str, budget: int = DEFAULT_BUDGET
) -> Minimized:
    """The smallest subset of ``schedule``'s faults whose run still fails with
    ``signature``, with that run's result."""
    results: dict[tuple[int, ...], RunResult] = {}

    def fails(items: list[Item]) -> bool:
        result = run_one(mission, schedule.only(items))
        results[tuple(id(i) for i in items)] = result
        return result.signature == signature

    kept, reruns, complete = ddmin(list(schedule.items), fails, budget)
    smallest = schedule.only(kept)
    result = results.get(tuple(id(i) for i in kept))
    if result is None:  # nothing could be taken away: the original run is the smallest
        result = run_one(mission, smallest)
        reruns += 1
    return Minimized(smallest, result, len(schedule.items), reruns, complete)
