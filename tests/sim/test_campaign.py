"""The randomized campaign: 200 seeded fault schedules, every invariant and the recovery.

A failure prints the schedule and the command that replays it
(``actorswarm swarm campaign --seed S``).
"""

from __future__ import annotations

import pytest

from actorswarm.sim.campaign import make_case, run_case

SEEDS = range(200)


@pytest.mark.campaign
@pytest.mark.parametrize("seed", SEEDS)
def test_fault_schedule(seed: int) -> None:
    result = run_case(make_case(seed))
    assert result.ok, "\n" + result.explain()


def test_cases_are_deterministic() -> None:
    first, second = make_case(17), make_case(17)
    assert first == second
    a, b = run_case(first), run_case(second)
    assert (a.violations, a.problems, a.fired_after_quiet) == (
        b.violations,
        b.problems,
        b.fired_after_quiet,
    )


def test_campaign_covers_every_fault_kind() -> None:
    kinds = {a.kind for s in SEEDS for a in make_case(s).actions}
    assert kinds == {"crash", "restart", "partition", "heal"}
    cases = [make_case(s) for s in SEEDS]
    assert any(c.link.burst is not None for c in cases), "no bursty-loss case"
    assert any(c.link.duplicate > 0 for c in cases), "no duplication case"
    assert any(c.link.reorder > 0 for c in cases), "no reordering case"
    assert any(c.link.loss >= 0.3 for c in cases), "no 30 % loss case"
    assert any(c.detector == "phi" for c in cases), "no phi-detector case"
    assert any(c.takeover for c in cases), "no take-over-on-join case"
