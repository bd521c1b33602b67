"""Long seeded fault campaigns on every core: many seeds, one or both membership modes.

:func:`run_campaign` runs the cases of :mod:`actorswarm.sim.campaign` for a range of seeds in
each requested membership mode, in worker processes, and hands every result to a callback as
it arrives. A case's verdict depends on its seed and mode only (:func:`run_case` is
deterministic and each case builds its own swarm), so a campaign gives the same verdicts with
one worker or many; only the order in which results arrive varies.

Cases travel to the workers in chunks of consecutive seeds, so the cost of a task (pickling,
a queue round trip) is small next to the simulation it carries, while chunks stay small
enough to keep every worker busy until the end and the progress fine-grained.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait

from actorswarm.core.config import MembershipKind
from actorswarm.sim.campaign import MEMBERSHIPS, CaseResult, check_membership, make_case, run_case

__all__ = ["Job", "campaign_jobs", "default_workers", "run_campaign", "run_job"]

#: One case of a campaign: (seed, membership mode).
Job = tuple[int, MembershipKind]

#: Most cases per task: about a second or two of simulation, so progress stays lively.
MAX_CHUNK = 8


def default_workers() -> int:
    """The CPUs this process may run on (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on every platform
        return max(1, os.cpu_count() or 1)


def campaign_jobs(
    start: int, count: int, membership: MembershipKind | Iterable[MembershipKind]
) -> list[Job]:
    """The cases of seeds ``start .. start + count - 1`` in each mode of ``membership``.

    Seed-major: every mode of a seed comes before the next seed, so a campaign cut short
    has covered the same seeds in each mode. Modes are deduplicated and run in the order of
    :data:`~actorswarm.sim.campaign.MEMBERSHIPS`. Raises :class:`ValueError` for a negative
    start or count, no mode, or an unknown mode.
    """
    if start < 0 or count < 0:
        raise ValueError(f"start and count must be >= 0, got start={start}, count={count}")
    wanted = {
        check_membership(m) for m in ([membership] if isinstance(membership, str) else membership)
    }
    if not wanted:
        raise ValueError("membership: no mode given")
    modes = [m for m in MEMBERSHIPS if m in wanted]
    return [(seed, mode) for seed in range(start, start + count) for mode in modes]


def run_job(job: Job, renew: bool = False) -> CaseResult:
    """Run one case (with renewable requests when ``renew``). An exception inside the case
    is a failure of that case (a problem with its traceback, and the replay command in its
    explanation), not of the campaign."""
    seed, membership = job
    case = make_case(seed, membership, renew=renew)
    try:
        return run_case(case)
    except Exception:
        return CaseResult(case, [], [f"the run raised:\n{traceback.format_exc().rstrip()}"])


def _run_chunk(jobs: list[Job], renew: bool = False) -> list[CaseResult]:
    return [run_job(job, renew) for job in jobs]


def _ignore_interrupt() -> None:
    # Ctrl-C reaches the whole process group: the parent alone handles it (cancels what is
    # queued, waits for the running chunks), so the workers do not print a traceback each.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _chunks(jobs: list[Job], size: int) -> Iterator[list[Job]]:
    for i in range(0, len(jobs), size):
        yield jobs[i : i + size]


def run_campaign(
    start: int,
    count: int,
    membership: MembershipKind | Iterable[MembershipKind] = "star",
    *,
    workers: int = 1,
    chunk: int | None = None,
    on_result: Callable[[CaseResult], None] | None = None,
    renew: bool = False,
) -> list[CaseResult]:
    """Run seeds ``start .. start + count - 1`` in each mode of ``membership``; return the
    failed results, ordered by seed, then mode.

    ``on_result`` is called in this process with every result, pass or fail, as it arrives:
    in job order with one worker, in completion order (chunk by chunk) with several.
    ``workers=1`` runs every case in this process, without a pool; more start that many
    worker processes (never more than there are chunks), each a fresh interpreter, so no
    state of this process reaches a case. ``chunk`` is the number of cases per task
    (default: up to :data:`MAX_CHUNK`, fewer when there are few cases per worker).
    ``renew``: every case with renewable barrier requests
    (:func:`~actorswarm.sim.campaign.make_case`).

    The verdict of every case is the same whatever ``workers`` and ``chunk`` are. An
    exception raised by ``on_result`` or a ``KeyboardInterrupt`` stops the campaign: queued
    chunks are cancelled, running ones are waited for, and the exception propagates.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if chunk is not None and chunk < 1:
        raise ValueError(f"chunk must be >= 1, got {chunk}")
    jobs = campaign_jobs(start, count, membership)
    failures: list[CaseResult] = []

    def record(result: CaseResult) -> None:
        if not result.ok:
            failures.append(result)
        if on_result is not None:
            on_result(result)

    if workers == 1 or len(jobs) <= 1:
        for job in jobs:
            record(run_job(job, renew))
    else:
        size = chunk or max(1, min(MAX_CHUNK, len(jobs) // (workers * 4)))
        tasks = list(_chunks(jobs, size))
        # "spawn": a fresh interpreter per worker, the same on every platform, and safe to
        # start while this process runs threads (a progress display).
        executor = ProcessPoolExecutor(
            max_workers=min(workers, len(tasks)),
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_ignore_interrupt,
        )
        try:
            pending: set[Future[list[CaseResult]]] = {
                executor.submit(_run_chunk, task, renew) for task in tasks
            }
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    for result in future.result():
                        record(result)
        finally:
            executor.shutdown(wait=True, cancel_futures=True)
    order = {mode: i for i, mode in enumerate(MEMBERSHIPS)}
    failures.sort(key=lambda r: (r.case.seed, order[r.case.membership]))
    return failures
