"""A whole ``task verify``: draw the schedules, run them, group the failures, minimize each
class, and (for a report directory) record each class's smallest failing run.

:func:`verify` is the engine of the command; it takes a :class:`~.pool.Pool` (where the
runs happen) and calls back with every run's result as it arrives, so the caller shows
progress. Stopped by ``KeyboardInterrupt`` while the runs go, it returns what it has, with
``interrupted`` set (no minimization then: the caller reports at once).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from actorswarm.sim.verify.minimize import DEFAULT_BUDGET, Minimized, minimize
from actorswarm.sim.verify.pool import Pool
from actorswarm.sim.verify.profile import FaultProfile
from actorswarm.sim.verify.runner import Mission, RunResult, run_one
from actorswarm.sim.verify.schedule import Schedule, draw

__all__ = ["FailureClass", "Outcome", "schedules", "verify", "wilson"]

#: Failure classes minimized at most (the largest first); the rest are listed with their
#: runs' full replay commands.
MAX_CLASSES = 10


@dataclass(slots=True)
class FailureClass:
    """The failed runs that share a signature, and the smallest schedule that fails so."""

    signature: str
    seeds: list[int]
    example: RunResult
    schedule: Schedule
    minimized: Minimized | None = None
    replay: str = ""
    recording: str | None = None

    def as_dict(self) -> dict[str, Any]:
        m = self.minimized
        return {
            "signature": self.signature,
            "runs": len(self.seeds),
            "seeds": self.seeds,
            "example_seed": self.example.seed,
            "replay": self.replay,
            "recording": self.recording,
            "faults": [i.text for i in (m.schedule if m else self.schedule).items],
            "minimized": None
            if m is None
            else {
                "from_faults": m.original,
                "to_faults": len(m.schedule.items),
                "reruns": m.reruns,
                "complete": m.complete,
                "still_fails": m.result.signature == self.signature,
                "why": m.result.why,
                "violations": m.result.violations,
                "crash": m.result.crash,
            },
        }


@dataclass(slots=True)
class Outcome:
    """Everything a verify found: every run's result, the failure classes (largest
    first)."""

    mission: Mission
    profile: FaultProfile
    first_seed: int
    planned: int
    results: list[RunResult] = field(default_factory=list)
    classes: list[FailureClass] = field(default_factory=list)
    interrupted: bool = False
    #: The whole command's time (set by the caller), and the runs' alone (the rest:
    #: minimizing, recording).
    wall_s: float = 0.0
    runs_s: float = 0.0
    where: str = ""

    @property
    def completed(self) -> int:
        return sum(r.completed for r in self.results)

    def completion_interval(self) -> tuple[float, float]:
        return wilson(self.completed, len(self.results))

    def violations(self) -> int:
        """Runs with an invariant violated or a separation breached."""
        return sum(1 for r in self.results if r.violations or r.breaches or r.crash)


def wilson(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """The Wilson score interval of a proportion (95 % by default); (0, 1) for n = 0. It
    stays inside [0, 1] and is meaningful at 0 and n successes, unlike the normal one."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # At 0 or n successes the interval reaches the bound exactly (not a rounding short).
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == n else min(1.0, centre + half)
    return low, high


def schedules(
    mission: Mission, profile: FaultProfile, first_seed: int, runs: int, platforms: Sequence[int]
) -> list[Schedule]:
    """The schedules of runs ``first_seed .. first_seed + runs - 1``."""
    return [
        draw(
            profile,
            seed,
            platforms,
            mission.duration,
            mission.events,
            vehicles=not mission.no_world,
        )
        for seed in range(first_seed, first_seed + runs)
    ]


def verify(
    mission: Mission,
    profile: FaultProfile,
    planned: Sequence[Schedule],
    pool: Pool,
    *,
    on_result: Callable[[RunResult], None] | None = None,
    on_minimized: Callable[[FailureClass], None] | None = None,
    budget: int = DEFAULT_BUDGET,
    minimize_classes: bool = True,
) -> Outcome:
    """Run every schedule of ``planned`` on ``pool``, then minimize each failure class."""
    outcome = Outcome(mission, profile, planned[0].seed if planned else 0, len(planned))
    by_seed = {s.seed: s for s in planned}
    chunk = 1 if len(planned) < 64 else 4
    began = time.perf_counter()
    try:
        for _, result in pool.map(run_one, [(mission, s) for s in planned], chunk=chunk):
            outcome.results.append(result)
            if on_result is not None:
                on_result(result)
    except KeyboardInterrupt:
        outcome.interrupted = True
    outcome.runs_s = time.perf_counter() - began
    outcome.results.sort(key=lambda r: r.seed)
    outcome.classes = _classes(outcome.results, by_seed)
    for cls in outcome.classes:
        cls.replay = mission.replay(cls.schedule)
    if outcome.interrupted or not minimize_classes:
        return outcome
    chosen = outcome.classes[:MAX_CLASSES]
    jobs = [(mission, c.schedule, c.signature, budget) for c in chosen]
    try:
        for i, minimized in pool.map(minimize, jobs):
            cls = chosen[i]
            cls.minimized = minimized
            if minimized.result.signature == cls.signature:
                cls.replay = mission.replay(minimized.schedule)
            if on_minimized is not None:
                on_minimized(cls)
    except KeyboardInterrupt:
        outcome.interrupted = True
    return outcome


def _classes(results: list[RunResult], by_seed: dict[int, Schedule]) -> list[FailureClass]:
    """The failures grouped by signature, largest class first; each class's example is its
    run with the fewest faults (the cheapest to minimize and to read)."""
    groups: dict[str, list[RunResult]] = {}
    for result in results:
        if not result.ok:
            groups.setdefault(result.signature, []).append(result)
    classes = []
    for signature, members in groups.items():
        example = min(members, key=lambda r: (len(by_seed[r.seed].items), r.seed))
        classes.append(
            FailureClass(signature, [r.seed for r in members], example, by_seed[example.seed])
        )
    classes.sort(key=lambda c: (-len(c.seeds), c.signature))
    return classes
