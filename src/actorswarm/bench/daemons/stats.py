"""Statistics of ``bench daemons``: what a switch cost the swarm, whether the machine was
crowded, the CPU per peer, and a plain verdict against a target. NaN is a run that did not
produce the figure; it is left out of every statistic here."""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence

from actorswarm.bench.daemons.results import BenchResult, ResourceRun
from actorswarm.bench.tables import percentile


def finite(values: Sequence[float]) -> list[float]:
    """``values`` without the NaNs."""
    return [v for v in values if not math.isnan(v)]


def p95(values: Sequence[float]) -> float:
    """The 95th percentile by nearest rank (with fewer than 20 values: the largest)."""
    return percentile(values, 0.95)


def same_processes(*samples: dict[int, int]) -> list[int]:
    """Each sample's CPU (ns, by process ID) summed over the processes found in every
    sample: a daemon that died or was restarted between two reads (a new process, its
    counter back near zero) would otherwise make the difference meaningless, even
    negative."""
    common = set(samples[0]).intersection(*samples[1:]) if samples else set()
    return [sum(sample[pid] for pid in common) for sample in samples]


def switch_cpu(
    idle: tuple[int, float], before: tuple[int, float], after: tuple[int, float]
) -> float:
    """CPU seconds a switch cost the swarm: what every daemon used from ``before`` (just
    before the event was sent) to ``after`` (once every platform switched and the last
    acknowledgements settled), less what it would have used idle over that time, at the
    rate measured from ``idle`` to ``before``. Each point is (summed CPU ns, clock s)."""
    (c0, t0), (c1, t1), (c2, t2) = idle, before, after
    if not t0 < t1 <= t2:
        raise ValueError(f"switch_cpu: times out of order: {t0}, {t1}, {t2}")
    rate = (c1 - c0) / (t1 - t0)
    return (c2 - c1 - rate * (t2 - t1)) / 1e9


def scarce(res: ResourceRun, cpus: int) -> bool:
    """Whether the daemons together used most of the machine in this window (then each
    got less CPU than it asked for)."""
    return sum(res.cpu_pct) >= 0.8 * 100.0 * max(1, cpus)


def cpu_fit(result: BenchResult) -> tuple[float, float, list[int]] | None:
    """CPU % per daemon at idle as ``a + b × peers``, least squares over the medians of the
    sizes that settled and where CPU was not scarce: (a, b, sizes used), or None with fewer
    than two such sizes."""
    cpus = int(result.machine.get("cpus") or 1)
    points = [
        (float(r.size - 1), statistics.median(res.cpu_pct), r.size)
        for r in result.sizes
        for res in r.resources
        if res.phase == "idle" and res.cpu_pct and not scarce(res, cpus)
    ]
    if len({x for x, _, _ in points}) < 2:
        return None
    xs, ys = [x for x, _, _ in points], [y for _, y, _ in points]
    slope, intercept = statistics.linear_regression(xs, ys)
    return intercept, slope, [n for _, _, n in points]


def verdict(values: Sequence[float], target: float, failed: int) -> str:
    """yes: every run within the target; "median only"; no."""
    clean = finite(values)
    if not clean:
        return "**no** (nothing measured)"
    if max(clean) <= target and not failed:
        return "yes"
    if statistics.median(clean) <= target:
        return "**median only**" + (f"; {failed} failed run(s)" if failed else "")
    return "**no**"
