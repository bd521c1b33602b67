"""The campaign runner and ``actorswarm swarm campaign``: seeds in parallel, both membership
modes, the same verdicts whatever the worker count, failures explained with their replay.

A handful of seeds each: the 200 seeds per mode are in test_campaign.py.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.sim import campaign_runner
from actorswarm.sim.campaign import Case, CaseResult, make_case
from actorswarm.sim.campaign_runner import campaign_jobs, run_campaign

runner = CliRunner()

CAMPAIGN = ("swarm", "campaign")
SUMMARY = re.compile(r"(\d+) passed, (\d+) failed in \d+\.\d s")


def _verdicts(results: list[CaseResult]) -> dict[tuple[int, str], tuple[object, ...]]:
    return {
        (r.case.seed, r.case.membership): (r.ok, r.violations, r.problems, r.fired_after_quiet)
        for r in results
    }


def test_the_verdicts_do_not_depend_on_the_worker_count() -> None:
    # Compares verdicts, not passes: it holds whether or not these seeds pass today.
    alone: list[CaseResult] = []
    failed_alone = run_campaign(2, 3, ("star", "broadcast"), workers=1, on_result=alone.append)
    pooled: list[CaseResult] = []
    failed_pooled = run_campaign(
        2, 3, ("star", "broadcast"), workers=2, chunk=2, on_result=pooled.append
    )
    assert len(alone) == len(pooled) == 6
    assert _verdicts(alone) == _verdicts(pooled)
    assert set(_verdicts(alone)) == {(s, m) for s in (2, 3, 4) for m in ("star", "broadcast")}
    assert [r.case for r in failed_alone] == [r.case for r in failed_pooled]
    assert [r.case for r in failed_alone] == [r.case for r in alone if not r.ok]


def test_jobs_are_seed_major_in_a_fixed_mode_order() -> None:
    assert campaign_jobs(5, 2, ("broadcast", "star", "star")) == [
        (5, "star"),
        (5, "broadcast"),
        (6, "star"),
        (6, "broadcast"),
    ]
    assert campaign_jobs(0, 2, "broadcast") == [(0, "broadcast"), (1, "broadcast")]
    with pytest.raises(ValueError, match="expected one of star, broadcast, got 'ring'"):
        campaign_jobs(0, 1, "ring")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="no mode"):
        campaign_jobs(0, 1, ())
    with pytest.raises(ValueError, match="workers must be >= 1"):
        run_campaign(0, 1, workers=0)


def _fake_run_case(failing: set[tuple[int, str]]) -> Callable[[Case], CaseResult]:
    """A stand-in for run_case: instant, failing exactly the (seed, mode) pairs given."""

    def run(case: Case) -> CaseResult:
        bad = (case.seed, case.membership) in failing
        return CaseResult(case, ["a made-up violation"] if bad else [])

    return run


def test_one_worker_runs_here_and_collects_the_failures(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_pool(*args: object, **kwargs: object) -> None:
        raise AssertionError("workers=1 must not start a pool")

    monkeypatch.setattr(campaign_runner, "ProcessPoolExecutor", no_pool)
    monkeypatch.setattr(campaign_runner, "run_case", _fake_run_case({(11, "broadcast")}))
    seen: list[tuple[int, str]] = []
    failures = run_campaign(
        10,
        3,
        ("star", "broadcast"),
        on_result=lambda r: seen.append((r.case.seed, r.case.membership)),
    )
    assert seen == campaign_jobs(10, 3, ("star", "broadcast"))
    assert [(r.case.seed, r.case.membership) for r in failures] == [(11, "broadcast")]


def test_a_case_that_raises_is_a_failure_not_a_crash(monkeypatch: pytest.MonkeyPatch) -> None:
    def explode(case: Case) -> CaseResult:
        raise RuntimeError(f"boom in seed {case.seed}")

    monkeypatch.setattr(campaign_runner, "run_case", explode)
    failures = run_campaign(7, 2, "broadcast")
    assert [r.case.seed for r in failures] == [7, 8]
    text = failures[0].explain()
    assert "RuntimeError: boom in seed 7" in text
    assert "replay: actorswarm swarm campaign --seed 7 --membership broadcast" in text


def test_a_failure_names_its_mode_and_the_command_that_replays_it() -> None:
    result = CaseResult(make_case(42, "broadcast"), ["t=3.000s: two masters in epoch 2"])
    assert not result.ok
    text = result.explain()
    assert text.startswith("FAILED seed 42: broadcast membership, ")
    assert "  replay: actorswarm swarm campaign --seed 42 --membership broadcast" in text
    assert "  violation: t=3.000s: two masters in epoch 2" in text
    assert make_case(42).replay == "actorswarm swarm campaign --seed 42 --membership star"


def test_cli_runs_seeds_on_two_workers() -> None:
    # Real cases in worker processes; whether they pass is the core's business, the summary
    # and the exit status must agree with each other either way.
    result = runner.invoke(
        app,
        [*CAMPAIGN, "--start", "0", "--count", "3", "--membership", "broadcast", "--workers", "2"],
    )
    assert "3 cases: seeds 0..2 in broadcast membership, 2 worker(s)" in result.output
    summary = SUMMARY.search(result.output)
    assert summary is not None, result.output
    passed, failed = int(summary[1]), int(summary[2])
    assert passed + failed == 3
    assert result.exit_code == (1 if failed else 0), result.output
    assert result.output.count("replay: ") == failed


def test_cli_both_runs_every_seed_in_each_mode(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(campaign_runner, "run_case", _fake_run_case({(21, "broadcast")}))
    result = runner.invoke(
        app,
        [*CAMPAIGN, "--start", "20", "--count", "2", "--membership", "both", "--workers", "1"],
    )
    assert result.exit_code == 1, result.output
    assert "4 cases: seeds 20..21 in star and broadcast membership" in result.output
    assert "FAILED seed 21: broadcast membership" in result.output
    assert "replay: actorswarm swarm campaign --seed 21 --membership broadcast" in result.output
    assert "3 passed, 1 failed in " in result.output


def test_cli_replays_one_seed_in_the_chosen_modes(monkeypatch: pytest.MonkeyPatch) -> None:
    from actorswarm.sim import campaign

    monkeypatch.setattr(campaign, "run_case", _fake_run_case(set()))
    result = runner.invoke(app, ["swarm", "campaign", "--seed", "5", "--membership", "both"])
    assert result.exit_code == 0, result.output
    assert "seed 5: star membership, " in result.output
    assert "seed 5: broadcast membership, " in result.output
    assert "2 passed, 0 failed in " in result.output
    result = runner.invoke(app, ["swarm", "campaign", "--seed", "5"])
    assert "seed 5: star membership, " in result.output
    assert "broadcast" not in result.output and "1 passed, 0 failed" in result.output


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--membership", "ring"], ["'--membership'", "'ring'", "'star', 'broadcast', 'both'"]),
        (["--workers", "0"], ["'--workers'"]),
        (["--count", "0"], ["'--count'"]),
    ],
)
def test_cli_refuses_bad_options_clearly(args: list[str], needles: list[str]) -> None:
    result = runner.invoke(app, [*CAMPAIGN, *args])
    assert result.exit_code == 2, result.output
    # The error is drawn in a box: compare the words, not the frame and the line breaks.
    words = " ".join(result.output.replace("│", " ").split())
    assert "Invalid value for" in words, result.output
    for needle in needles:
        assert needle in words, result.output


def test_renew_reaches_every_case_in_the_workers_and_in_a_replay(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    pooled: list[CaseResult] = []
    run_campaign(30, 2, "star", workers=2, chunk=1, on_result=pooled.append, renew=True)
    assert sorted((r.case.seed, r.case.renew) for r in pooled) == [(30, True), (31, True)]
    from actorswarm.sim import campaign

    failing = _fake_run_case({(5, "star")})
    monkeypatch.setattr(campaign, "run_case", failing)
    result = runner.invoke(app, ["swarm", "campaign", "--seed", "5", "--renew"])
    assert result.exit_code == 1, result.output
    assert "seed 5: star membership, renewable requests, " in result.output
    assert "replay: actorswarm swarm campaign --seed 5 --membership star --renew" in result.output
