"""Single-platform Actor switch time (docs/design.md §8: ≤ 1 ms median; the paper: 104 ms).

A switch is measured from the call to :meth:`ActorRuntime.switch` — pause the current actor
and free its hardware, then start the next: plugin group instantiated and started, params
validated, hardware bound — to the end of the next actor's first OODA step.

* ``cold``: the next actor is not loaded (its plugins are built and started; the actor
  switched away from is unloaded after each measurement, untimed);
* ``warm``: the next actor is sleeping from an earlier switch and is re-activated.

Each actor holds ``plugins`` plugins (``core.idle`` spread over the four buses) and the
exclusive resource ``autopilot`` is *not* used, so the figure is the framework's own cost.
This measures wall time (``time.perf_counter``); it is a benchmark, not a test.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import asdict, dataclass

from actorswarm.bench.scripts import actor_element, platforms_element
from actorswarm.dsl import check
from actorswarm.engine.runtime import ActorContext
from actorswarm.runtime.actor_runtime import ActorRuntime


@dataclass(frozen=True, slots=True)
class SwitchRow:
    plugins: int
    mode: str  # cold | warm
    runs: int
    median_ms: float
    p99_ms: float
    min_ms: float
    max_ms: float


def _script(actors: int, plugins: int) -> str:
    body = "".join(actor_element(f"S{n}", plugins) for n in range(actors))
    return (
        f'<TaskScript name="bench" version="1"><_ActorsConfig>{body}</_ActorsConfig>'
        f"<_TaskConfig/>{platforms_element(1, 'S0')}</TaskScript>"
    )


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def measure(plugins: int, mode: str, runs: int) -> SwitchRow:
    """Time ``runs`` switches of one kind."""
    result = check(_script(2, plugins), path="bench.xml")
    assert result.script is not None
    rt = ActorRuntime(1, rate=10.0)
    rt.use_script(result.script)
    now = 0.0
    rt.start("S0", now, ActorContext())
    rt.step(now)
    current = "S0"
    if mode == "warm":
        rt.switch("S0", "S1", now, ActorContext())  # S1 loaded once: later switches are warm
        rt.step(now)
        current = "S1"
    samples = []
    for _ in range(runs):
        now += 0.1
        target = "S0" if current == "S1" else "S1"
        began = time.perf_counter()
        rt.switch(current, target, now, ActorContext())
        rt.step(now)
        samples.append((time.perf_counter() - began) * 1000.0)
        if mode == "cold":
            rt.stop(current, now)  # unloaded: the next switch back loads it afresh
        current = target
    return SwitchRow(
        plugins=plugins,
        mode=mode,
        runs=runs,
        median_ms=statistics.median(samples),
        p99_ms=_percentile(samples, 0.99),
        min_ms=min(samples),
        max_ms=max(samples),
    )


def run(plugin_counts: list[int], runs: int) -> list[SwitchRow]:
    return [measure(p, mode, runs) for p in plugin_counts for mode in ("cold", "warm")]


def markdown(rows: list[SwitchRow]) -> str:
    lines = [
        "Single Actor switch on one platform (pause the current actor, start or re-activate "
        "the next, until its first OODA step); target ≤ 1 ms median, the paper 104–105 ms.",
        "",
        "| plugins | mode | runs | median ms | p99 ms | min ms | max ms |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.plugins} | {r.mode} | {r.runs} | {r.median_ms:.3f} | {r.p99_ms:.3f} "
            f"| {r.min_ms:.3f} | {r.max_ms:.3f} |"
        )
    lines.append("")
    worst = max(r.median_ms for r in rows)
    verdict = "meets" if worst <= 1.0 else "MISSES"
    lines.append(f"Worst median {worst:.3f} ms: {verdict} the 1 ms target.")
    return "\n".join(lines) + "\n"


def to_json(rows: list[SwitchRow]) -> list[dict[str, object]]:
    return [asdict(r) for r in rows]
